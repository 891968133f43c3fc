"""Cost and error of the transport delay's buffer: sine -> transport_delay (tau = 0.3 s) -> first_order.

2 s by RK4 at 1 ms; the first run includes the compile (compiled path), the second reuses it.
Usage: python3 benchmarks/bench_transport_delay.py N [compiled|fused|generic]   (N: buffer samples)
"""
import sys
import time

import numpy as np

import hybridsim as hs
import hybridsim.blocks  # noqa: F401  (registers the library)

N, path = int(sys.argv[1]), (sys.argv[2] if len(sys.argv) > 2 else "compiled")
tau, t_end = 0.3, 2.0
lookup = hs.registry.lookup
d = hs.Diagram("bench")
d.add(lookup("sine")("s", amplitude=1.0, frequency=1.0))
d.add(lookup("transport_delay")("d", delay=tau, buffer=N))
d.add(lookup("first_order")("f", tau=0.05))
d.connect("s.y", "d.u")
d.connect("d.y", "f.u")
kw = {"compiled": dict(compiled=True), "fused": {}, "generic": dict(fused=False)}[path]
sim = hs.Simulator(d.build(), hs.RK4(1e-3), log=["d.y"], log_period=0.01, **kw)
t1 = time.perf_counter()
sim.run(t_end)
t2 = time.perf_counter()
res = sim.run(t_end)
t3 = time.perf_counter()
err = float(np.max(np.abs(res["d.y[0]"] - np.where(res.t >= tau, np.sin(2 * np.pi * (res.t - tau)), 0.0))))
bound = (tau / N) ** 2 / 8 * (2 * np.pi) ** 2
print(f"path={path} N={N} first_run={t2 - t1:.2f}s second_run={t3 - t2:.2f}s events={len(res.meta['events'])}"
      f" err={err:.2e} bound={bound:.2e}")
