use invsim_runtime::{forward, Cycle, ForwardOptions, Method};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let tend: f64 = args[1].parse().unwrap();
    let model = invsim_models::builtin("si_engine").unwrap();
    let mut cycle = Cycle::builtin("nedc").unwrap();
    let n = cycle.time.iter().position(|&t| t >= tend).unwrap();
    cycle.time.truncate(n); cycle.speed.truncate(n); cycle.time.push(tend); cycle.speed.push(cycle.speed_at(tend));
    let o = ForwardOptions { dt: 0.25, method: Method::Dopri5, ..Default::default() };
    match forward(model.as_ref(), &cycle, &o) {
        Ok(f) => { for k in 0..f.len() { println!("{:.2} {:.5} {:.5} {:.1} {:.6}", f.time()[k], f.cycle_speed()[k], f.column("v").unwrap()[k], f.column("p_i").unwrap()[k], f.input()[k]); } println!("{}", f.summary.to_text()); }
        Err(e) => println!("{e}"),
    }
}
