//! navfuse-io: streaming readers and writers. Units and frame conversions
//! happen here and nowhere else; errors name file, line and field.

pub mod data;
pub mod kfgins_yaml;
