use std::time::Instant;
#[test]
fn phases() {
    let src = format!("domain [-1,1]^3;\nsurface x{};", " + 1".repeat(100_000));
    let t = Instant::now();
    let (toks, _) = isoc::syntax::lexer::lex(&src);
    println!("lex {:?} {}", t.elapsed(), toks.len());
    let t = Instant::now();
    let ast = isoc::syntax::parser::parse(&src);
    println!("lex+parse {:?}", t.elapsed());
    let t = Instant::now();
    let mut d = vec![];
    let r = isoc::syntax::resolve::resolve(&ast, &src, &Default::default(), true, &mut d);
    println!("resolve {:?}", t.elapsed());
    let t = Instant::now();
    let p = isoc::syntax::lower::lower_surface(&ast, &r).unwrap();
    println!("lower {:?} {}", t.elapsed(), p.len());
    let t = Instant::now();
    drop(ast);
    println!("drop {:?}", t.elapsed());
}
