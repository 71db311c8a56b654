"""The harness's sub-packages stand in layers: each imports only from the layers below it (never
upwards, so no cycles), function-local and type-checking imports included; the SLAM packages and
the simulator never import the harness."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HARNESS = ROOT / "harness"
# lowest first; the packages of one layer do not import each other
LAYERS = (("run",), ("camera", "report"), ("record",), ("figures",), ("sweeps", "navigation"), ("cli",))
RANK = {package: i for i, layer in enumerate(LAYERS) for package in layer}


def _imported(path: Path) -> set[str]:
    """Every module ``path`` imports, relative imports resolved to absolute names."""
    here = list(path.relative_to(ROOT).with_suffix("").parts)
    package = here[:-1]  # a module's package; an __init__'s is the package itself
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                out.add(node.module or "")
                continue
            base = package[: len(package) - (node.level - 1)]
            if node.module:
                out.add(".".join([*base, node.module]))
            else:
                out |= {".".join([*base, a.name]) for a in node.names}
    return out


def test_every_harness_module_is_in_a_sub_package_with_a_docstring():
    assert sorted(p.name for p in HARNESS.glob("*.py")) == ["__init__.py"]
    packages = sorted(p.parent.name for p in HARNESS.glob("*/__init__.py"))
    assert packages == sorted(RANK)
    for name in packages:
        assert ast.get_docstring(ast.parse((HARNESS / name / "__init__.py").read_text())), name


def test_sub_packages_import_only_from_layers_below():
    upwards = []
    for path in sorted(HARNESS.glob("*/*.py")):
        package = path.parent.name
        for name in _imported(path):
            parts = name.split(".")
            other = parts[1] if parts[0] == "harness" and len(parts) > 1 else package
            if other != package and (other not in RANK or RANK[other] >= RANK[package]):
                upwards.append(f"{path.relative_to(ROOT)} imports {name}")
    assert not upwards, "\n".join(upwards)


def test_slam_packages_and_simulator_never_import_the_harness():
    found = [
        f"{path.relative_to(ROOT)} imports {name}"
        for package in ("slamkit", "ratslam", "baselines", "worlds")
        for path in sorted((ROOT / package).rglob("*.py"))
        for name in _imported(path)
        if name.split(".")[0] == "harness"
    ]
    assert not found, "\n".join(found)
