//! Walking patterns for the second seed's comparison: the footstep plan and reference ZMP of its
//! gait, the ZMP preview controller that turns them into a CoM trajectory (Kajita et al.
//! 2003, in Katayama's integral form) and the online Torso Position Control that corrects the
//! walk from the measured ZMP. Pure: no I/O.

pub mod gait;
pub mod preview;
pub mod torso;

pub use gait::{FootPose, Gait, GaitSample, Side};
pub use preview::{PreviewController, PreviewParams};
pub use torso::{Effort, EffortMeter, TorsoControl, TorsoParams};
