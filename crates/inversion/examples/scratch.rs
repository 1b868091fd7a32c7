fn main() {
    for f in std::env::args().skip(1) {
        match invsim_inversion::derive_file(f.as_ref()) {
            Ok(d) => println!("{}\n{}", d.to_text(), serde_json::to_string_pretty(&d.to_json()).unwrap()),
            Err(e) => println!("ERR {e}"),
        }
    }
}
