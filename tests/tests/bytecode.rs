//! Bundles: the disassembler output is snapshot-tested, the opcode documentation is
//! generated from the one opcode table and must be up to date, and every bundle
//! round-trips through encode/decode unchanged.

use mdg_tests::{build_source, mdg_files, root, snapshot};

#[test]
fn disassembly_snapshots() {
    for path in mdg_files("tests/disasm") {
        let text = std::fs::read_to_string(&path).expect("read");
        let bundle = build_source(&text);
        let dis = mdg_vm::bundle::disassemble(&bundle);
        // Readable text, not Rust debug output of the bundle's structures.
        for leak in ["Some(", "None", "Call(", "Push(", "Bin(", "PrimAdj", "kind", "::", "?", ".0,", " { "] {
            assert!(!dis.contains(leak), "{}: the disassembly shows `{leak}`:\n{dis}", path.display());
        }
        snapshot(&path.with_extension("disasm"), &dis).expect("snapshot");
    }
}

#[test]
fn bundles_round_trip() {
    for path in mdg_files("std/examples") {
        let text = std::fs::read_to_string(&path).expect("read");
        let bundle = build_source(&text);
        let bytes = mdg_vm::bundle::encode(&bundle);
        let back = mdg_vm::bundle::load(&bytes).expect("a fresh bundle loads");
        assert_eq!(back, bundle, "{} changed through encode/decode", path.display());
        assert_eq!(mdg_vm::bundle::encode(&back), bytes);
    }
}

/// `docs/bytecode.md` lists every opcode exactly as the table in vm/src/bundle/ops.rs.
#[test]
fn opcode_documentation_is_generated_from_the_table() {
    let mut doc = String::from(
        "# Bytecode\n\n\
         Generated from the opcode table in `vm/src/bundle/ops.rs` (`for_each_op!`); the test\n\
         `tests/tests/bytecode.rs` fails when this file is out of date (regenerate with\n\
         `UPDATE_EXPECT=1 cargo test -p mdg-tests --test bytecode`).\n\n\
         Notation: `start` is the frame an item starts from (the body's frame, the iterator\n\
         run's frame, or the continuation state after `\\`); `X[x]` is transform `x`; `last`\n\
         is the continuation register. Operands are little-endian after the opcode byte.\n\n\
         | byte | mnemonic | operands and meaning |\n|---|---|---|\n",
    );
    for (byte, mn, meaning) in mdg_vm::bundle::ops::OPCODES {
        doc.push_str(&format!("| 0x{byte:02x} | `{mn}` | `{}` |\n", meaning.replace('|', "\\|")));
    }
    doc.push_str("\nDrawable kinds of `DRAW`: ");
    doc.push_str(
        &mdg_vm::bundle::ops::DRAWABLE_KINDS
            .iter()
            .enumerate()
            .map(|(i, k)| format!("{i} `{k}`"))
            .collect::<Vec<_>>()
            .join(", "),
    );
    doc.push_str(".\n\nAdjustment ops of dynamic transforms (one byte each, then an axis byte): ");
    doc.push_str(
        &mdg_vm::bundle::AdjOp::ALL
            .iter()
            .map(|a| format!("{} `{}` (≤ {} arguments)", *a as u8, a.family(), a.max_args()))
            .collect::<Vec<_>>()
            .join(", "),
    );
    doc.push_str(".\n");
    snapshot(&root().join("docs/bytecode.md"), &doc).expect("docs/bytecode.md is out of date");
}
