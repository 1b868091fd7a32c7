use invsim_runtime::{forward, simulate, Bounds, Cycle, ForwardOptions, SimulationOptions, Method};
fn main() {
    let model = invsim_models::builtin("si_engine").unwrap();
    let cycle = Cycle::builtin("nedc").unwrap();
    let dt = 0.01;
    let inv = simulate(model.as_ref(), &cycle, &SimulationOptions { dt, keep_series: false, ..Default::default() }).unwrap();
    let t = std::time::Instant::now();
    for _ in 0..10 { simulate(model.as_ref(), &cycle, &SimulationOptions { dt, ..Default::default() }).unwrap(); }
    println!("inverse {:?}", t.elapsed()/10);
    for method in [Method::Dopri5, Method::Rosenbrock23] {
      for rtol in [1e-6, 1e-8, 1e-10] {
        for bounds in [Bounds::Ignore, Bounds::Enforce] {
        let o = ForwardOptions { dt, method, rtol, atol: rtol*1e-2, bounds, ..Default::default() };
        let t = std::time::Instant::now();
        let f = forward(model.as_ref(), &cycle, &o).unwrap();
        let tf = t.elapsed();
        let s = &f.summary;
        println!("{:?} rtol {rtol:e} {:?}: {:?} {} steps {} rej {} evals {} fuel {:.4}% maxerr {:.4} misses {:?}", method, bounds, tf, s.integrator.method.as_str(), s.integrator.stats.accepted, s.integrator.stats.rejected, s.integrator.stats.evaluations,
          100.0*(s.integrals["fuel"]/inv.summary.integrals["fuel"]-1.0), s.max_abs_tracking_error*3.6, s.trace_misses.len());
        }
      }
    }
    let o = ForwardOptions { dt, keep_series: true, ..Default::default() };
    let f = forward(model.as_ref(), &cycle, &o).unwrap();
    for k in 79380..79420 { if k % 4 == 0 { println!("{} v {:e} p {} u {:e}", f.time()[k], f.column("v").unwrap()[k], f.column("p_i").unwrap()[k], f.input()[k]); } }
}
