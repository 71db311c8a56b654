"""Configuration files (``--config FILE.toml``): round trip, one-line errors, and a run's own
``config.toml`` reproducing it bit for bit (the run-directory and CLI contracts)."""

import json

import pytest

from baselines import BackendConfig, KeyframeConfig, PoseGraphConfig, YawBiasConfig
from harness.run.config_file import ConfigFileError, config_toml, read_config_file
from ratslam import ExperienceMapConfig, PoseCellConfig, RatSLAMConfig
from tests.helpers import cli


def test_effective_config_round_trips_exactly(tmp_path):
    rs = RatSLAMConfig(
        pose_cells=PoseCellConfig(nx=48, cell_size_m=0.1 + 0.2, path_integration_bias_deg_s=-1e-17),
        experience_map=ExperienceMapConfig(energy="sum", offset_transitions=False),
    )
    pg = PoseGraphConfig(
        keyframes=KeyframeConfig(distance_m=1.0 / 3.0),
        backend=BackendConfig(kind="gaussian", estimator_k=2.5),
    ).replace(closures={"flush_distance": float("inf")})
    path = tmp_path / "c.toml"
    text = config_toml(rs, pg, "header")
    path.write_text(text)
    assert "[ratslam.pose_cells]\nnx = 48\n" in text and '[gtsam.backend]\nkind = "gaussian"\n' in text
    got = read_config_file(path).apply(RatSLAMConfig(), PoseGraphConfig())
    assert got == (rs, pg)  # floats bit for bit (repr)
    assert config_toml(*got, "header") == text
    default = tmp_path / "d.toml"  # None fields are left unset
    default.write_text(config_toml(RatSLAMConfig(), PoseGraphConfig()))
    assert read_config_file(default).apply(RatSLAMConfig(), PoseGraphConfig()) == (RatSLAMConfig(), PoseGraphConfig())


def test_values_go_on_top_of_the_given_configs(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text("[ratslam.experience_map]\nr_inf_cells = 3\n[gtsam]\nclosures.max_candidates = 2\n")
    rs, pg = read_config_file(path).apply(
        RatSLAMConfig(pose_cells=PoseCellConfig(nx=40)), PoseGraphConfig(yaw_bias=YawBiasConfig(estimate=True))
    )
    em = rs.experience_map
    assert (rs.pose_cells.nx, em.r_inf_cells, type(em.r_inf_cells), em.theta_inf_cells) == (40, 3.0, float, 2.0)
    assert (pg.yaw_bias.estimate, pg.closures.max_candidates) == (True, 2)


@pytest.mark.parametrize(
    "text, expected",
    [
        ("[ratslm.pose_cells]\nnx = 40\n", "[ratslm]: unknown table"),
        ("[ratslam.pose_cells]\nnxx = 40\n", "[ratslam.pose_cells] nxx: unknown key (not a field of PoseCellConfig)"),
        ("[ratslam]\nnx = 40\n", "[ratslam] nx: unknown key (not a field of RatSLAMConfig)"),
        (
            '[ratslam]\n"pose_cells.nx" = 40\n',
            "[ratslam] pose_cells.nx: unknown key (not a field of RatSLAMConfig); a quoted",
        ),
        ("[ratslam.pose_cell]\nnx = 40\n", "[ratslam] pose_cell: unknown key"),
        ("[ratslam]\npose_cells = 40\n", "[ratslam] pose_cells: expected a table [ratslam.pose_cells], got 40"),
        ("[ratslam.pose_cells.nx]\n", "[ratslam.pose_cells] nx: expected a value, got a table"),
        ("[ratslam.pose_cells]\nnx = 40.5\n", "[ratslam.pose_cells] nx: must be an integer >= 4, got 40.5"),
        ("[gtsam.optimisation]\nonline = 1\n", "[gtsam.optimisation] online: must be True or False, got 1"),
        ("[gtsam.backend]\nkind = 3\n", "[gtsam.backend] kind: must be one of 'gaussian', 'robust', 'gnc', got 3"),
        ("[ratslam]\npose_cells.nx = 3\n", "[ratslam.pose_cells] nx: must be an integer >= 4, got 3"),
        ('[gtsam.backend]\nkind = "magic"\n', "[gtsam.backend] kind: must be one of 'gaussian', 'robust', 'gnc'"),
        ('[gtsam.yaw_bias]\nestimate = true\n[gtsam.backend]\nkind = "gnc"\n', "[gtsam.yaw_bias] estimate: not avail"),
        ("[ratslam.reentry]\nposition_sigma_m = 0.0\n", "[ratslam.reentry] position_sigma_m/heading_sigma_deg: both"),
        ("[ratslam.pose_cells]\nnx = \n", "not valid TOML"),
        ("ratslam = 3\n", "ratslam: expected a table [ratslam]"),
    ],
)
def test_bad_config_is_one_line_naming_file_table_key(tmp_path, text, expected):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigFileError) as e:
        read_config_file(path)
    msg = str(e.value)
    assert msg.startswith(str(path)) and expected in msg and "\n" not in msg, msg


def test_cli_bad_config_exits_2_and_writes_nothing(tmp_path):
    log = tmp_path / "log.csv"
    assert cli("simulate", "small_loop", "--out", str(log), "--duration", "20", "--quiet").returncode == 0
    bad = tmp_path / "bad.toml"
    bad.write_text("[gtsam.keyframes]\ndistanse_m = 1.0\n")
    for args in (("replay", str(log), "--out", str(tmp_path / "OUT")), ("run", "fig7", "--out", str(tmp_path / "OUT"))):
        r = cli(*args, "--config", str(bad), "--quiet", "--no-recording")
        assert r.returncode == 2 and "[gtsam.keyframes] distanse_m: unknown key" in r.stderr, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1
        assert not (tmp_path / "OUT").exists()


def _without_machine(node):
    if isinstance(node, dict):
        return {k: _without_machine(v) for k, v in node.items() if k not in ("timing", "provenance", "log", "title")}
    return node


def test_a_runs_config_toml_reproduces_it_bit_for_bit(tmp_path):
    """Contract: ``replay LOG --config RUN/config.toml`` reproduces that run's metrics and
    trajectories exactly (here with non-default values in both tables)."""
    log = tmp_path / "log.csv"
    assert cli("simulate", "small_loop", "--out", str(log), "--duration", "120", "--quiet").returncode == 0
    first = tmp_path / "first.toml"
    first.write_text(
        '[ratslam.experience_map]\nr_inf_cells = 2.5\nenergy = "sum"\n[gtsam.keyframes]\ndistance_m = 0.4\n'
    )
    a, b = tmp_path / "a", tmp_path / "b"
    assert cli("replay", str(log), "--out", str(a), "--config", str(first), "--quiet", "--no-recording").returncode == 0
    text = (a / "config.toml").read_text()
    assert "[ratslam.experience_map]\nview_confirm_ticks = 2\n" in text and "r_inf_cells = 2.5" in text
    assert 'energy = "sum"' in text and "[gtsam.keyframes]\ndistance_m = 0.4\n" in text
    r = cli("replay", str(log), "--out", str(b), "--config", str(a / "config.toml"), "--quiet", "--no-recording")
    assert r.returncode == 0, r.stderr
    ma, mb = (json.loads((d / "metrics.json").read_text()) for d in (a, b))
    assert _without_machine(ma) == _without_machine(mb)
    for tum in ("ratslam.tum", "gtsam.tum"):
        assert (a / "trajectories" / tum).read_bytes() == (b / "trajectories" / tum).read_bytes()
    # and the configuration did take effect (the default differs)
    c = tmp_path / "c"
    assert cli("replay", str(log), "--out", str(c), "--quiet", "--no-recording").returncode == 0
    assert (c / "trajectories" / "gtsam.tum").read_bytes() != (a / "trajectories" / "gtsam.tum").read_bytes()
