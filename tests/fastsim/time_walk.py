#!/usr/bin/env python3
"""Time FASTSim 3's `SimDrive(veh, cyc).walk()` of the 2012 Ford Fusion on UDDS (its own 1 s grid), to set
beside the criterion bench `cargo bench -p invsim-bench --bench fusion_udds` (the imported Fusion on the same
cycle, in-process). The median over REPEATS runs after one warm-up run; the SimDrive is built inside the
timed call, as each FASTSim run needs a fresh one.

    python tests/fastsim/time_walk.py [REPEATS]
"""

import statistics
import sys
import time
import warnings

warnings.filterwarnings("ignore", category=DeprecationWarning)
import fastsim  # noqa: E402


def main():
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    veh = fastsim.Vehicle.from_resource("2012_Ford_Fusion.yaml")
    cyc = fastsim.Cycle.from_resource("udds.csv")
    params = fastsim.SimParams.default().to_dict()
    params["trace_miss_opts"] = "Allow"
    params = fastsim.SimParams.from_dict(params)

    def run():
        sd = fastsim.SimDrive(veh, cyc, params)
        sd.walk()
        return sd

    run()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        run()
        times.append(time.perf_counter() - t0)
    med = statistics.median(times)
    steps = len(cyc.to_dict()["time_seconds"])
    print(f"FASTSim {fastsim.__version__} walk, 2012 Ford Fusion, UDDS ({steps} steps): median {med * 1e3:.2f} ms"
          f" over {repeats} runs ({med / steps * 1e6:.2f} us per step)")


if __name__ == "__main__":
    main()
