"""Fuzzing generated from the format's tables: every key of every section, --set values, sweep files,
subsystem trees. Bounded (a few hundred cases); the long run is ``python benchmarks/fuzz_tables.py``."""
import pytest
from hypothesis import HealthCheck, given, settings

from fuzz_tables import check_case, diagrams, set_options, subsystem_trees, sweep_files

FAST = settings(max_examples=80, deadline=None, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck))


@pytest.mark.slow
@FAST
@given(diagrams())
def test_sections_drawn_from_their_tables_keep_the_invariants(doc):
    check_case("check", doc)


@FAST
@given(set_options())
def test_set_options_keep_the_invariants(options):
    check_case("check", options=options)


@settings(max_examples=30, deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck))
@given(sweep_files())
def test_sweep_files_drawn_from_their_table_keep_the_invariants(sweep):
    check_case("sweep", sweep=sweep)


@pytest.mark.slow
@FAST
@given(subsystem_trees())
def test_subsystem_trees_keep_the_invariants(tree):
    top, files = tree
    check_case("check", top, files)
