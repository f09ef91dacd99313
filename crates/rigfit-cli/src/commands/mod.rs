//! One module per subcommand.

pub mod demo_rig;
pub mod info;
