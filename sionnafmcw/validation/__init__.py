"""Validation experiments: each module has ``main(argv) -> int`` that writes PNG figures and a
``metrics.json`` to ``--out`` and prints the metrics JSON as its last line (exit status 1 when a
target is missed). The scripts in the repository's ``validation/`` folder and the command line
``sionnafmcw validate NAME`` both call these.
"""

from __future__ import annotations

import importlib

#: name -> one-line description
EXPERIMENTS = {
    "point_targets": "analytic point targets through synthesis and processing (range, velocity, angle, SNR)",
    "circle_walk": "the paper's walking person on a 3 m circle: Doppler-time against truth, e_velo",
    "pixel_vs_path": "pixel engine against the single-bounce path engine on the same scenes",
}


def names() -> list[str]:
    """The validation experiments, in a stable order."""
    return list(EXPERIMENTS)


def run(name: str, argv=None) -> int:
    """Run experiment ``name`` with command-line arguments ``argv``; returns its exit status."""
    if name not in EXPERIMENTS:
        raise ValueError(f"validation experiment {name!r} is unknown; choose one of {', '.join(names())}")
    module = importlib.import_module(f".{name}", __name__)
    return module.main(argv)


__all__ = ["EXPERIMENTS", "names", "run"]
