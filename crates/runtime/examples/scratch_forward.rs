use invsim_runtime::{forward, simulate, Bounds, Cycle, ForwardOptions, SimulationOptions};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let kp: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(2.0);
    let ki: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1.0);
    let bounds = if args.get(3).map(|s| s.as_str()) == Some("enforce") { Bounds::Enforce } else { Bounds::Ignore };
    let model = invsim_models::builtin("si_engine").unwrap();
    let cycle = Cycle::builtin("nedc").unwrap();
    let dt = 0.01;
    let t = std::time::Instant::now();
    let inv = simulate(model.as_ref(), &cycle, &SimulationOptions { dt, ..Default::default() }).unwrap();
    let ti = t.elapsed();
    let o = ForwardOptions { dt, kp, ki, bounds, ..Default::default() };
    let t = std::time::Instant::now();
    let f = forward(model.as_ref(), &cycle, &o).unwrap();
    let tf = t.elapsed();
    let s = &f.summary;
    println!("{}", s.to_text());
    println!("inverse {:?} forward {:?} ratio {:.1}", ti, tf, tf.as_secs_f64()/ti.as_secs_f64());
    let fi = inv.summary.integrals["fuel"]; let ff = s.integrals["fuel"];
    println!("fuel inverse {fi} forward {ff} diff {:.3} %", 100.0*(ff-fi)/fi);
    // error away from corners
    let corners: Vec<f64> = cycle.time.iter().zip(cycle.speed.iter()).enumerate().filter(|(i,_)| {
        let i=*i; if i==0 || i+1==cycle.time.len() {return false;}
        let s0=(cycle.speed[i]-cycle.speed[i-1])/(cycle.time[i]-cycle.time[i-1]);
        let s1=(cycle.speed[i+1]-cycle.speed[i])/(cycle.time[i+1]-cycle.time[i]);
        (s1-s0).abs()>1e-12 }).map(|(_, (t,_))| *t).collect();
    let y = f.column("v").unwrap(); let yc = f.cycle_speed(); let tt = f.time();
    let mut worst=(0.0,0.0);
    for k in 0..tt.len() { if corners.iter().any(|c| (tt[k]-c).abs()<2.0) {continue;}
        let e=(y[k]-yc[k]).abs()*3.6; if e>worst.0 {worst=(e,tt[k]);} }
    println!("max err away from corners {:.4} km/h at t={}", worst.0, worst.1);
    let mut worst=(0.0,0.0);
    for k in 0..tt.len() { let e=(y[k]-yc[k]).abs()*3.6; if e>worst.0 {worst=(e,tt[k]);} }
    println!("max err overall {:.4} km/h at t={}", worst.0, worst.1);
    println!("inverse violations {:?}", inv.summary.input_bound_violations);
}
