use invsim_runtime::{forward, Bounds, Cycle, ForwardOptions, Method};
fn main() {
    let mut model = invsim_models::builtin("si_engine").unwrap();
    let cycle = Cycle::builtin("nedc").unwrap();
    for vi in [2.5e-3, 2.5e-4, 2.5e-5] {
      model.set_param("V_i", vi).unwrap();
      for method in [Method::Dopri5, Method::Rosenbrock23] {
        for bounds in [Bounds::Ignore, Bounds::Enforce] {
        let o = ForwardOptions { dt: 0.01, method, bounds, keep_series: false, ..Default::default() };
        let t = std::time::Instant::now();
        match forward(model.as_ref(), &cycle, &o) { Ok(f) => {
        let s = &f.summary;
        println!("V_i {vi:e} {:?} {:?}: {:?} {} steps {} rej {} evals {} maxerr {:.4} misses {}", method, bounds, t.elapsed(), s.integrator.method.as_str(), s.integrator.stats.accepted, s.integrator.stats.rejected, s.integrator.stats.evaluations, s.max_abs_tracking_error*3.6, s.trace_misses.len()); }
        Err(e) => println!("V_i {vi:e} {:?} {:?}: {e}", method, bounds) }
        }
      }
    }
}
