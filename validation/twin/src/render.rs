//! Headless frames of a twin (MuJoCo's renderer on EGL, e.g. Mesa's software rasteriser):
//! behind the crate feature `renderer`.
//!
//! MuJoCo's OpenGL context creation can stop the process when the driver is unusable, so the
//! validation renders in a child process (`zmp-twin silo2 render-frames`) and reports a failure
//! instead of dying with it.

use crate::mj::TwinError;
use crate::silo2::validate::FrameState;
use crate::silo2::Silo2;
use mujoco_rs::prelude::*;
use mujoco_rs::renderer::MjRenderer;
use std::path::{Path, PathBuf};

/// Image size, px (the model's offscreen buffer must be at least this big).
pub const WIDTH: u32 = 640;
pub const HEIGHT: u32 = 480;

/// Geom group of the 4 kg load (shown only in frames where it is on).
pub const LOAD_GROUP: usize = 3;

/// Renders one PNG per state from the model's camera `camera` into `out`; returns the files.
pub fn render_frames(
    twin: &Silo2,
    camera: &str,
    states: &[FrameState],
    out: &Path,
) -> Result<Vec<PathBuf>, TwinError> {
    let err = |message: String| TwinError::Model {
        path: twin.path.clone(),
        message,
    };
    let cam = twin
        .model
        .name_to_id(MjtObjBase::mjOBJ_CAMERA, camera)
        .ok_or_else(|| err(format!("no camera named '{camera}'")))?;
    let nq = twin.model.nq() as usize;
    for (k, s) in states.iter().enumerate() {
        if s.qpos.len() != nq || !s.qpos.iter().all(|v| v.is_finite()) {
            return Err(err(format!(
                "frame {k}: qpos has {} values (the model has {nq}) or a non-finite one",
                s.qpos.len()
            )));
        }
    }
    std::fs::create_dir_all(out).map_err(|e| err(format!("creating {}: {e}", out.display())))?;
    let mut renderer = MjRenderer::builder()
        .width(WIDTH)
        .height(HEIGHT)
        .camera(MjvCamera::new_fixed(cam))
        .png_compression(mujoco_rs::renderer::png::Compression::Balanced)
        .build(&twin.model)
        .map_err(|e| err(format!("cannot open a headless OpenGL context (EGL): {e}")))?;
    let mut d = twin.stand()?;
    let mut files = Vec::new();
    for s in states {
        d.qpos_mut().copy_from_slice(&s.qpos);
        d.qvel_mut().fill(0.0);
        d.forward();
        renderer.opts_mut().geomgroup[LOAD_GROUP] = u8::from(s.loaded);
        renderer
            .sync_data(&mut d)
            .and_then(|()| renderer.render())
            .map_err(|e| err(format!("rendering t = {} s: {e}", s.t)))?;
        let file = out.join(format!("t{:05.1}s.png", s.t));
        renderer
            .save_rgb(&file)
            .map_err(|e| err(format!("writing {}: {e}", file.display())))?;
        files.push(file);
    }
    Ok(files)
}
