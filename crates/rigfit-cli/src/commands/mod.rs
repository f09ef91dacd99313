//! One module per subcommand.

pub mod demo;
pub mod demo_rig;
pub mod info;
pub mod pose;
pub mod render;
pub mod surface;
pub mod track;
