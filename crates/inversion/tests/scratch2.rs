use invsim_expr::{parse, Pool};

#[test]
fn depth() {
    let kind = std::env::var("K").unwrap();
    let n: usize = std::env::var("N").unwrap().parse().unwrap();
    let stack: usize = std::env::var("S").unwrap().parse().unwrap();
    let src = match kind.as_str() {
        "pow" => vec!["x"; n].join("^"),
        "sum" => vec!["x*y"; n].join("+"),
        "neg" => format!("{}x", "-".repeat(n)),
        _ => format!("{}x{}", "sin(".repeat(n), ")".repeat(n)),
    };
    std::thread::Builder::new().stack_size(stack << 10).spawn(move || {
        let ast = parse(&src).unwrap();
        let _ = ast.identifiers();
        let mut pool = Pool::new();
        let e = pool.from_ast(&ast);
        let x = pool.symbol("x");
        let d = pool.diff(e, x);
        let _ = pool.display(d);
        let m = std::collections::HashMap::from([(x, pool.sym("y"))]);
        let _ = pool.substitute(e, &m);
    }).unwrap().join().unwrap();
}
