"""The demo's rig section (configs/demo.yaml) for the benchmarks' simulated Ch. 4 experiments."""

from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
DEMO_RIG = yaml.safe_load((ROOT / "configs/demo.yaml").read_text(encoding="utf-8"))["rig"]
