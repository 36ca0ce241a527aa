//! Generates the parser from `grammar/isoc.lalrpop`.
fn main() {
    lalrpop::Configuration::new()
        .use_cargo_dir_conventions()
        .process_dir("grammar")
        .expect("lalrpop grammar failed to build");
    println!("cargo:rerun-if-changed=grammar");
}
