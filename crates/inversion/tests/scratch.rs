use invsim_inversion::Model;
use std::path::Path;

#[test]
fn scratch() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/malformed");
    let mut es: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    es.sort();
    for p in es {
        let text = std::fs::read_to_string(&p).unwrap();
        let name = p.file_name().unwrap().to_str().unwrap();
        match Model::from_path(&p) {
            Ok(_) => println!("!!! {name} LOADED"),
            Err(e) => {
                println!("== {name}: {:?} {:?}:{:?} {}", e.kind, e.line, e.column, e.message);
                if let (Some(l), Some(c)) = (e.line, e.column) {
                    let line = text.lines().nth(l - 1).unwrap_or("");
                    println!("   |{line}\n   |{}^", " ".repeat(c - 1));
                }
            }
        }
    }
}
