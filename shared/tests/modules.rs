//! No import circle inside the crate: at every level of the module tree, the modules under one
//! parent use each other without a cycle (`fbg_testkit::modules`, which the trainer's
//! `tests/modules.rs` tests and applies to its own tree).

use std::path::Path;

#[test]
fn no_module_cycle_in_the_crate() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    if let Err(e) = fbg_testkit::modules::check(&src) {
        panic!("{e}");
    }
}
