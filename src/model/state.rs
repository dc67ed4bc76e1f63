//! The layout of the rig's state: the base model's components, before any effect's.

/// Index of the body displacement `x` \[m\] in the state.
pub const X: usize = 0;
/// Index of the body velocity `v` [m/s].
pub const V: usize = 1;
/// Index of the contact deformation `s` \[m\].
pub const S: usize = 2;
/// Number of state components of the base model.
pub const BASE_DIM: usize = 3;
