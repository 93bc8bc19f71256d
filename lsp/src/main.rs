//! MDG language server.
fn main() {}
