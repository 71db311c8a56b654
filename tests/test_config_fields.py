"""The shared configuration validator (ratslam/config_fields.py): one rule per kind of field,
the same for RatSLAM and the pose graph, and one-line errors naming the field's dotted path."""

import dataclasses
from typing import ClassVar, Literal

import numpy as np
import pytest

from baselines import BackendConfig, KeyframeConfig, LoopClosureConfig, OptimisationConfig, PoseGraphConfig
from ratslam import (
    ExperienceMapConfig,
    LocalViewConfig,
    PoseCellConfig,
    RatSLAMConfig,
    ReentryFusionConfig,
    YawBiasConfig,
)
from slamkit.config_fields import ConfigError, check_fields, from_dict, param, replace, subconfigs


@dataclasses.dataclass(frozen=True)
class Toy:
    """Every kind of field the validator knows."""

    SECTION: ClassVar[str] = "toy"

    count: int = param(1, ge=1)
    ratio: float = param(0.5, gt=0, lt=1)
    limit: float = param(1.0, gt=0, finite=False)
    maybe: int | None = param(None, ge=0)
    flag: bool = False
    mode: Literal["a", "b"] = "a"

    def __post_init__(self) -> None:
        check_fields(self)


def _error(make) -> str:
    with pytest.raises(ConfigError) as e:
        make()
    message = str(e.value)
    assert "\n" not in message
    return message


def test_numpy_numbers_accepted_and_stored_as_python_numbers():
    toy = Toy(count=np.int64(3), ratio=np.float32(0.25), limit=np.int32(2), maybe=np.uint8(0))
    assert (toy.count, toy.ratio, toy.limit, toy.maybe) == (3, 0.25, 2.0, 0)
    assert [type(v) for v in (toy.count, toy.ratio, toy.limit, toy.maybe)] == [int, float, float, int]


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"count": True}, "toy.count: must be an integer >= 1, got True"),
        ({"count": np.bool_(True)}, "toy.count: must be an integer >= 1, got"),
        ({"count": 2.0}, "toy.count: must be an integer >= 1, got 2.0"),
        ({"count": 0}, "toy.count: must be an integer >= 1, got 0"),
        ({"ratio": False}, "toy.ratio: must be a finite number in (0, 1), got False"),
        ({"ratio": 1.0}, "toy.ratio: must be a finite number in (0, 1), got 1.0"),
        ({"ratio": float("inf")}, "toy.ratio: must be a finite number in (0, 1), got inf"),
        ({"ratio": "0.5"}, "toy.ratio: must be a finite number in (0, 1), got '0.5'"),
        ({"limit": float("nan")}, "toy.limit: must be a number (inf allowed) > 0, got nan"),
        ({"maybe": -1}, "toy.maybe: must be None or an integer >= 0, got -1"),
        ({"flag": 1}, "toy.flag: must be True or False, got 1"),
        ({"flag": np.bool_(True)}, "toy.flag: must be True or False, got"),
        ({"mode": "c"}, "toy.mode: must be one of 'a', 'b', got 'c'"),
        ({"mode": None}, "toy.mode: must be one of 'a', 'b', got None"),
    ],
)
def test_bad_values_are_one_line_naming_the_field(changes, message):
    assert _error(lambda: Toy(**changes)).startswith(message)


def test_infinity_only_where_declared():
    assert Toy(limit=float("inf")).limit == float("inf")
    assert Toy(maybe=None).maybe is None


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: PoseCellConfig(nx=2), "pose_cells.nx: must be an integer >= 4, got 2"),
        (lambda: PoseCellConfig(trans_gain=True), "pose_cells.trans_gain: must be a finite number > 0, got True"),
        (lambda: LoopClosureConfig(max_candidates=True), "closures.max_candidates: must be an integer >= 1, got True"),
        (lambda: KeyframeConfig(distance_m=True), "keyframes.distance_m: must be a finite number > 0, got True"),
        (lambda: LocalViewConfig(learn_threshold=1.0), "local_view.learn_threshold: must be a finite number in [0, 1)"),
        (lambda: ExperienceMapConfig(energy="max"), "experience_map.energy: must be one of 'sum', 'product'"),
        (lambda: ExperienceMapConfig(offset_transitions=1), "experience_map.offset_transitions: must be True or False"),
        (lambda: BackendConfig(kind="lm"), "backend.kind: must be one of 'gaussian', 'robust', 'gnc', got 'lm'"),
        (lambda: OptimisationConfig(online=np.bool_(True)), "optimisation.online: must be True or False"),
        (lambda: RatSLAMConfig(pose_cells=None), "pose_cells: must be a PoseCellConfig, got None"),
        (lambda: PoseCellConfig(nx=5, ny=5, n_theta=5), "pose_cells.excite_radius_cells/inhibit_radius_cells/"),
        (lambda: ReentryFusionConfig(position_sigma_m=0.0), "reentry.position_sigma_m/heading_sigma_deg: both 0"),
        (lambda: YawBiasConfig(search_max_deg_s=-1.0), "yaw_bias.search_max_deg_s: must be a finite number > 0"),
    ],
)
def test_both_packages_apply_the_same_rules(make, message):
    assert _error(make).startswith(message)


@pytest.mark.parametrize("top", [RatSLAMConfig, PoseGraphConfig])
def test_every_sub_config_validates_its_fields(top):
    """A sub-config that forgot to call check_fields would let a bad value through to the SLAM."""
    for name, cls in subconfigs(top).items():
        for f in dataclasses.fields(cls):
            with pytest.raises(ConfigError, match=f"^{name}.{f.name}: must be "):
                cls(**{f.name: object()})


def test_both_packages_accept_numpy_integers():
    assert RatSLAMConfig(pose_cells=PoseCellConfig(nx=np.int64(60))) == RatSLAMConfig()
    assert PoseGraphConfig(closures=LoopClosureConfig(max_candidates=np.int64(1))) == PoseGraphConfig()


def test_replace_takes_nested_changes_and_names_unknown_fields():
    cfg = replace(RatSLAMConfig(), {"pose_cells": {"nx": 40}, "experience_map": {"energy": "sum"}})
    assert (cfg.pose_cells.nx, cfg.pose_cells.ny, cfg.experience_map.energy) == (40, 60, "sum")
    assert cfg == RatSLAMConfig().replace(pose_cells=PoseCellConfig(nx=40), experience_map={"energy": "sum"})
    assert _error(lambda: RatSLAMConfig().replace(pose_cells={"nxx": 40})).startswith("pose_cells.nxx: unknown")
    assert _error(lambda: RatSLAMConfig().replace(nx=40)).startswith("nx: unknown field of RatSLAMConfig")


def test_from_dict_inverts_asdict():
    for cfg in (
        RatSLAMConfig(reentry=ReentryFusionConfig(position_sigma_m=0.5, heading_sigma_deg=2.0)),
        PoseGraphConfig(closures=LoopClosureConfig(batch_keyframes=3, flush_distance=float("inf"))),
    ):
        assert from_dict(type(cfg), dataclasses.asdict(cfg)) == cfg
    assert from_dict(RatSLAMConfig, {"pose_cells": {"nx": 40}}).pose_cells.shape == (40, 60, 36)
    assert _error(lambda: from_dict(PoseGraphConfig, {"backend": {"kindd": "gnc"}})).startswith("backend.kindd:")
