//! Generates the parser from `grammar/isoc.lalrpop` into `OUT_DIR`.
fn main() {
    lalrpop::Configuration::new()
        .process_dir("grammar")
        .expect("lalrpop grammar failed to build");
    println!("cargo:rerun-if-changed=grammar");
}
