import pytest
"""Property-based fuzzing of check and run with mutated diagrams (bounded: under a minute).

The longer run is ``python benchmarks/fuzz_entry_points.py --examples N``.
"""
from hypothesis import HealthCheck, given, settings

from fuzz_diagrams import check_invariants, mutated_diagrams


@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mutated_diagrams())
@pytest.mark.slow
def test_mutated_diagrams_keep_the_invariants(text):
    check_invariants(text)


@pytest.mark.slow
def test_the_unmutated_bases_run():
    from fuzz_diagrams import BASES

    import yaml

    for doc in BASES:
        assert check_invariants(yaml.safe_dump(doc)) == 0
