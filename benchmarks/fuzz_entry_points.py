"""The long fuzz run of check and run on mutated diagrams (on demand, not in the tests).

    python benchmarks/fuzz_entry_points.py --examples 2000 [--seed 1]

Same generator and invariants as tests/format/test_fuzz.py (tests/fuzz_diagrams.py),
more examples and a random seed; prints how many cases ended in each exit code
and the first case that breaks an invariant (hypothesis shrinks it).
"""
import argparse
import collections
import time
from pathlib import Path

from hypothesis import HealthCheck, given, seed, settings


def _fuzz_module():
    """tests/fuzz_diagrams.py, loaded by path (tests/ on sys.path would shadow the block library)."""
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "tests" / "fuzz_diagrams.py"
    spec = importlib.util.spec_from_file_location("fuzz_diagrams", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--examples", type=int, default=2000)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args()
    codes = collections.Counter()
    fz = _fuzz_module()

    @seed(a.seed)
    @settings(max_examples=a.examples, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(fz.mutated_diagrams())
    def fuzz(text):
        codes[fz.check_invariants(text)] += 1

    t0 = time.perf_counter()
    fuzz()
    print(f"{sum(codes.values())} cases in {time.perf_counter() - t0:.0f} s; final exit codes: "
          + ", ".join(f"{k}: {v}" for k, v in sorted(codes.items())))


if __name__ == "__main__":
    from results import recorded  # benchmarks/results.py: the dated section in RESULTS.md

    with recorded("Fuzzing the entry points"):
        main()
