"""The long run of the table-generated fuzz (on demand, not in the tests).

    python benchmarks/fuzz_tables.py --examples 1000 [--seed 1]

Same strategies and invariants as tests/format/test_fuzz_tables.py (tests/fuzz_tables.py):
each of the four families (sections, --set options, sweep files, subsystem trees)
gets ``--examples`` cases; prints how many ended in each exit status, the slowest
case's time, and the first case that breaks an invariant (hypothesis shrinks it).
"""
import argparse
import collections
import importlib.util
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"
sys.path.insert(0, str(ROOT))  # this checkout's hybridsim, not an installed one

from hypothesis import HealthCheck, given, seed, settings  # noqa: E402


def _module():
    spec = importlib.util.spec_from_file_location("fuzz_tables", TESTS / "fuzz_tables.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _counting(case, codes, slowest):
    def one(x):
        t0 = time.perf_counter()
        codes[case(x)] += 1
        slowest[0] = max(slowest[0], time.perf_counter() - t0)
    return one


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--examples", type=int, default=1000)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args()
    fz = _module()
    families = {
        "sections": (fz.diagrams(), lambda doc: fz.check_case("check", doc)),
        "--set": (fz.set_options(), lambda opts: fz.check_case("check", options=opts)),
        "sweep files": (fz.sweep_files(), lambda sw: fz.check_case("sweep", sweep=sw)),
        "subsystem trees": (fz.subsystem_trees(), lambda tree: fz.check_case("check", tree[0], tree[1])),
    }
    total = 0
    for name, (strategy, case) in families.items():
        codes, slowest = collections.Counter(), [0.0]
        test = seed(a.seed)(settings(max_examples=a.examples, deadline=None, database=None,
                                     suppress_health_check=list(HealthCheck))(given(strategy)(_counting(case, codes, slowest))))
        t0 = time.perf_counter()
        test()
        n = sum(codes.values())
        total += n
        print(f"{name}: {n} cases in {time.perf_counter() - t0:.0f} s, exit codes {dict(sorted(codes.items()))}, "
              f"slowest {slowest[0]:.2f} s", flush=True)
    print(f"all: {total} cases, every one a documented exit status")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(TESTS))
    sys.exit(main())
