"""Where the project's bundled configs and reference data live."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CONFIG_DIR = ROOT / "configs"
DEFAULT_SIMULATE_CONFIG = CONFIG_DIR / "simulate.yaml"
#: the paper's tables (Tables 1-14, Section 7.3) as CSV
REFERENCE_DIR = ROOT / "data" / "reference"
PAPER_ELLIPSOID_TABLES = REFERENCE_DIR / "paper_ellipsoid_tables.csv"
DEFAULT_HAND = CONFIG_DIR / "hands" / "human.yaml"
DEFAULT_OBJECT = CONFIG_DIR / "objects" / "tool.yaml"
DEFAULT_SOLVER_CONFIG = CONFIG_DIR / "solver.yaml"
DEFAULT_GRASP_CONFIG = CONFIG_DIR / "grasp.yaml"
DEFAULT_PHYSICS_CONFIG = CONFIG_DIR / "physics.yaml"


def as_paths(options: object, *names: str, optional: tuple[str, ...] = ()) -> None:
    """The named fields of a frozen options dataclass as Paths, those in ``optional`` unless None: a notebook's
    strings are welcome wherever a path is."""
    for name in names + optional:
        value = getattr(options, name)
        if value is not None or name not in optional:
            object.__setattr__(options, name, Path(value))
