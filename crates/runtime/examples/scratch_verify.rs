use invsim_runtime::{simulate, Cycle, SimulationOptions};
fn main() {
    let model = invsim_models::builtin("si_engine").unwrap();
    let cycle = Cycle::builtin("nedc").unwrap();
    for dt in [0.01, 0.02, 0.05, 0.1, 0.2] {
        let o = SimulationOptions { dt, verify: true, ..Default::default() };
        let t = std::time::Instant::now();
        let r = simulate(model.as_ref(), &cycle, &o).unwrap();
        println!("dt {dt}: max {:e} rms {:e} ({:?}) warnings {:?}", r.summary.max_abs_tracking_error.unwrap(), r.summary.rms_tracking_error.unwrap(), t.elapsed(), r.summary.warnings.len());
        println!("  fuel {:?} umin {}", r.summary.integrals, r.summary.input_min);
    }
}
