//! The front end: lexer, parser, name resolution, lowering to IR. (stub until the front-end branch lands)

use crate::surface::{Bounds, CompileOptions};
use crate::{Error, ir};

/// What the front end produces.
pub struct Lowered {
    pub program: ir::Program,
    pub domain: Bounds,
    pub params: Vec<(String, f64)>,
}

pub fn front_end(source: &str, file: &str, opts: &CompileOptions) -> Result<Lowered, Error> {
    let _ = (source, file, opts);
    Err(Error::Usage("front end not merged".into()))
}

pub fn emit_ast(source: &str, file: &str) -> Result<String, Error> {
    let _ = (source, file);
    Err(Error::Usage("front end not merged".into()))
}

/// Source text from a file's bytes; invalid UTF-8 is a located error.
pub fn source_from_bytes(bytes: &[u8], file: &str) -> Result<String, Error> {
    let _ = file;
    Ok(String::from_utf8_lossy(bytes).into_owned())
}
