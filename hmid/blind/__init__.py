"""Blind suites: does the loop name the physics a simulation switched on but never declared?"""

from hmid.blind.cases import (
    CLEAN,
    Case,
    dataset_for,
    declare,
    experiment_for,
    outcome,
    plan_cases,
)
from hmid.blind.config import BlindSuite, load_suite
from hmid.blind.table import check_targets, suite_counts, suite_table

__all__ = [
    "CLEAN",
    "BlindSuite",
    "Case",
    "check_targets",
    "dataset_for",
    "declare",
    "experiment_for",
    "load_suite",
    "outcome",
    "plan_cases",
    "suite_counts",
    "suite_table",
]
