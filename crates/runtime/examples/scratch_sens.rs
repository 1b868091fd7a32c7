use invsim_runtime::{forward, simulate, Cycle, ForwardOptions, SimulationOptions};
fn main() {
    let model = invsim_models::builtin("si_engine").unwrap();
    let cycle = Cycle::builtin("nedc").unwrap();
    for dt in [0.01, 0.1] {
    let inv = simulate(model.as_ref(), &cycle, &SimulationOptions { dt, ..Default::default() }).unwrap();
    let fi = inv.summary.integrals["fuel"];
    for (kp, ki, w, ff) in [(2.0,1.0,10.0,true),(2.0,1.0,5.0,true),(2.0,1.0,20.0,true),(1.0,0.25,10.0,true),(4.0,4.0,10.0,true),(2.0,1.0,10.0,false)] {
        let o = ForwardOptions { dt, kp, ki, response: w, feedforward: ff, ..Default::default() };
        let t = std::time::Instant::now();
        let f = forward(model.as_ref(), &cycle, &o).unwrap();
        let el = t.elapsed();
        let y = f.column("v").unwrap(); let yc = f.cycle_speed(); let tt = f.time();
        let corners: Vec<f64> = (1..cycle.time.len()-1).filter(|&i| {
            let s0=(cycle.speed[i]-cycle.speed[i-1])/(cycle.time[i]-cycle.time[i-1]);
            let s1=(cycle.speed[i+1]-cycle.speed[i])/(cycle.time[i+1]-cycle.time[i]); (s1-s0).abs()>1e-12}).map(|i| cycle.time[i]).collect();
        let mut w2=0.0f64; for k in 0..tt.len() { if corners.iter().any(|c| (tt[k]-c).abs()<2.0) {continue;} w2=w2.max((y[k]-yc[k]).abs()*3.6); }
        println!("dt {dt} kp {kp} ki {ki} w {w} ff {ff}: fuel {:+.3}% max {:.3} km/h, away {:.3} km/h, {:?}, steps {}", 100.0*(f.summary.integrals["fuel"]/fi-1.0), f.summary.max_abs_tracking_error*3.6, w2, el, f.summary.integrator.stats.accepted);
    }}
    for dt in [1.0, 0.1, 0.01] {
        let o = ForwardOptions { dt, keep_series: false, ..Default::default() };
        let t = std::time::Instant::now(); for _ in 0..5 { forward(model.as_ref(), &cycle, &o).unwrap(); } println!("forward dt {dt}: {:?}", t.elapsed()/5);
        let o = SimulationOptions { dt, keep_series: false, ..Default::default() };
        let t = std::time::Instant::now(); for _ in 0..5 { simulate(model.as_ref(), &cycle, &o).unwrap(); } println!("inverse dt {dt}: {:?}", t.elapsed()/5);
    }
}
