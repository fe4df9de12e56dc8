//! What a person looks at: SVG plots ([`plot`]) and the self-contained HTML reports of the
//! identification ([`identify`]) and of compare and diagnose ([`diagnose`]), with what they
//! share ([`html`]), and the summary and figure of the robust-stability check ([`robust`]).

pub mod diagnose;
pub mod html;
pub mod identify;
pub mod plot;
pub mod robust;
