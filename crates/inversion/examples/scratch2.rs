use invsim_model_api::InverseModel;
fn main() {
    let d = invsim_inversion::derive_file("models/si_engine.toml".as_ref()).unwrap();
    let it = invsim_inversion::Interpreter::new(&d).unwrap();
    for v in [0.0, 15.0/3.6, 50.0/3.6, 70.0/3.6, 120.0/3.6] {
        let mut x = [0.0; 2];
        let u = it.invert(&[v, 0.0], &[], 0.0, &mut x).unwrap();
        println!("v={v} p_i={} m_at={} g/s  alpha={} beta={}", x[1], u*1000.0, it.alpha(&[v,0.0],&[]), it.beta(&[v,0.0],&[]));
    }
}
