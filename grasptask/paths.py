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
