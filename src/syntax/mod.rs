//! The front end: lexer, parser, name resolution, lowering to IR. (in progress)
