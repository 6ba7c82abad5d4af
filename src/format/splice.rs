// placeholder until the splice branch lands
use crate::mode::Mode;
#[derive(Debug, Clone, PartialEq)]
pub enum KeyEdit { Set { t: f64, value: String }, Move { index: usize, t: f64 }, Delete { index: usize } }
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpliceError { #[error("x")] X }
pub fn edit_keys(_text: &str, _mode: Mode, _edit: &KeyEdit) -> Result<String, SpliceError> { Err(SpliceError::X) }
pub fn number(x: f64) -> String { format!("{x:?}") }
