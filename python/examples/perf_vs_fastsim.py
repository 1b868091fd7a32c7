"""Time per run, from Python: invsim's inverse simulation of si_engine and of the 6-speed dynamic 2012 Ford Fusion
(gearbox, idle, fuel cut-off and friction brake as modes) on UDDS at dt = 1 s against FASTSim 3's
`SimDrive(veh, cyc).walk()` of the 2012 Ford Fusion on UDDS (FASTSim only if it is installed).

    python python/examples/perf_vs_fastsim.py [REPEATS]

Both are timed the same way: the median over REPEATS runs of the whole call, after one warm-up run. invsim's
figure includes smoothing the cycle, the inversion and the extra outputs, with the series kept (the columns
handed to numpy) and with only the summary (`keep_series=False`); the model is loaded once. A run's summary
is turned into a dict when it is first read (`Result.summary`): the third figure reads it too.
"""

import statistics
import sys
import time
from pathlib import Path

import invsim

REPO = Path(__file__).resolve().parents[2]


def median_time(f, repeats):
    f()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def fastsim_run():
    """A callable running FASTSim once, or None when FASTSim is not installed."""
    try:
        import fastsim
    except ImportError:
        return None
    veh = fastsim.Vehicle.from_resource("2012_Ford_Fusion.yaml")
    cyc = fastsim.Cycle.from_resource("udds.csv")

    def run():
        sd = fastsim.SimDrive(veh, cyc)
        sd.walk()
        return sd

    return run


def main():
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 50
    model = invsim.Model(REPO / "models" / "si_engine.toml")
    full = median_time(lambda: model.simulate(cycle="udds", dt=1.0), repeats)
    light = median_time(lambda: model.simulate(cycle="udds", dt=1.0, keep_series=False), repeats)
    read = median_time(lambda: model.simulate(cycle="udds", dt=1.0).summary["integrals"], repeats)
    print("invsim si_engine UDDS dt=1 ({}): {:.3f} ms per run, {:.3f} ms summary only, {:.3f} ms with the "
          "summary read".format(model.engine, full * 1e3, light * 1e3, read * 1e3))
    fusion = invsim.Model(REPO / "models" / "ford_fusion_2012_dynamic_6speed.toml")
    car = median_time(lambda: fusion.simulate(cycle="udds", dt=1.0), repeats)
    car_light = median_time(lambda: fusion.simulate(cycle="udds", dt=1.0, keep_series=False), repeats)
    print("invsim 6-speed dynamic Fusion UDDS dt=1 ({}): {:.3f} ms per run, {:.3f} ms summary only".format(
        fusion.engine, car * 1e3, car_light * 1e3))
    run = fastsim_run()
    if run is None:
        print("FASTSim is not installed (pip install fastsim): no comparison")
        return
    fs = median_time(run, max(5, repeats // 5))
    print("FASTSim 2012 Fusion UDDS walk(): {:.3f} ms per run".format(fs * 1e3))
    print("ratio si_engine: {:.0f}x (series kept), {:.0f}x (summary only), {:.0f}x (summary read)".format(
        fs / full, fs / light, fs / read))
    print("ratio 6-speed dynamic Fusion: {:.1f}x (series kept), {:.1f}x (summary only)".format(
        fs / car, fs / car_light))


if __name__ == "__main__":
    main()
