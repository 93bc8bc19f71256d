//! Geometry kernels of the VM: the thesis's quaternion frames, the BLENDTO spline,
//! profile sweeps, isosurface polygonisation and flat paths (fill and stroke).
//!
//! Everything here is pure: functions take frames and profiles and append to a
//! [`Mesh`] (defined here, so the kernels depend on nothing else in the VM); none
//! of it knows about bytecode or rule evaluation.

pub mod blend;
pub mod frame64;
pub mod marching;
pub mod mesh;
pub mod path;
pub mod quat;
pub mod rotation;
pub mod sweep;

pub use blend::{blend_frames, BLEND_LAMBDA};
pub use marching::{polygonize, Grid};
pub use mesh::Mesh;
pub use quat::{Affine, Frame};
pub use rotation::rotation_between;
pub use sweep::{average_frame, sweep, sweep_averaged, sweep_oriented, sweep_path};
