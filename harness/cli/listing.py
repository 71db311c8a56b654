"""``ratslam-harness list``: the paper's figures, the shipped worlds and the experiments."""

from __future__ import annotations

from worlds import list_worlds, load_world


def add_parser(sub) -> None:
    sub.add_parser("list", help="list shipped worlds").set_defaults(func=command)


def command(args) -> None:
    from ..figures.registry import FIGURES

    print("figures:")
    for fig in FIGURES.values():
        source = fig.world or f"real log {fig.real_log}"
        length = "whole log" if fig.duration is None else f"{fig.duration / 60:g} min"
        print(f"  {fig.name:<7} {fig.title} [{source}, {length}]")
    print("worlds:")
    for name in list_worlds():
        w = load_world(name)
        print(f"  {name:<14} {w.size[0]:g} m x {w.size[1]:g} m, {w.duration / 60:g} min default")
    print("experiments:")
    print("  nav            goal navigation on RatSLAM's experience map and GTSAM's pose graph (nav WORLD)")
