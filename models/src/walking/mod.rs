//! Walking patterns for the second seed's comparison: the footstep plan and reference ZMP of its
//! gait, and the ZMP preview controller that turns them into a CoM trajectory (Kajita et al.
//! 2003, in Katayama's integral form). Pure: no I/O.

pub mod gait;
pub mod preview;

pub use gait::{FootPose, Gait, GaitSample, Side};
pub use preview::{PreviewController, PreviewParams};
