//! Loading MJCF models with errors that name the file, and the small checked helpers the twins
//! share.

use mujoco_rs::prelude::*;
use std::path::{Path, PathBuf};

/// What can go wrong before or while MuJoCo runs a twin.
#[derive(Debug, thiserror::Error)]
pub enum TwinError {
    /// The MJCF file cannot be read.
    #[error("{path}: cannot read the MJCF file: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why it cannot be read.
        source: std::io::Error,
    },
    /// MuJoCo's compiler rejected the model.
    #[error("{path}: MuJoCo rejected the model: {message}")]
    Load {
        /// The model's file (or its name, for a model built in memory).
        path: String,
        /// MuJoCo's message.
        message: String,
    },
    /// The model loaded but lacks something the twin needs (a body, joint or sensor).
    #[error("{path}: {message}")]
    Model {
        /// The model's file (or its name).
        path: String,
        /// What is missing or wrong.
        message: String,
    },
}

/// Loads an MJCF file. The file is read and checked first, so MuJoCo only sees a readable XML
/// document; MuJoCo's own compile errors come back as [`TwinError::Load`].
pub fn load_mjcf(path: &Path) -> Result<MjModel, TwinError> {
    let text = std::fs::read_to_string(path).map_err(|source| TwinError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    if !text.trim_start().starts_with('<') {
        return Err(TwinError::Load {
            path: path.display().to_string(),
            message: "not an XML document".into(),
        });
    }
    // Relative asset paths (meshes, included files) resolve against the file's folder.
    MjModel::from_xml(path).map_err(|e| TwinError::Load {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}

/// Loads an MJCF document held in memory; `name` is used in errors.
pub fn load_mjcf_str(xml: &str, name: &str) -> Result<MjModel, TwinError> {
    if xml.contains('\0') {
        return Err(TwinError::Load {
            path: name.into(),
            message: "the document contains a NUL byte".into(),
        });
    }
    MjModel::from_xml_string(xml).map_err(|e| TwinError::Load {
        path: name.into(),
        message: e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOX_ON_FLOOR: &str = r#"
<mujoco>
  <option timestep="0.001"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="box" pos="0 0 0.05">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.05" mass="2"/>
    </body>
  </worldbody>
</mujoco>"#;

    #[test]
    fn a_box_settles_on_the_floor_under_gravity() {
        let model = load_mjcf_str(BOX_ON_FLOOR, "box.xml").unwrap();
        let mut data = model.make_data();
        for _ in 0..2000 {
            data.step();
        }
        // The free joint's z (qpos[2]) ends at the half height, within MuJoCo's soft contact
        // penetration (millimetres at the default solref).
        let z = data.qpos()[2];
        assert!((z - 0.05).abs() < 2e-3, "box centre at z = {z}");
        // Total normal force carries the weight.
        let fz: f64 = (0..data.ncon() as usize)
            .map(|i| data.contact_force(i)[0])
            .sum();
        assert!(
            (fz - 2.0 * 9.81).abs() < 0.05 * 2.0 * 9.81,
            "normal force {fz} N"
        );
    }

    #[test]
    fn bad_models_are_errors_not_exits() {
        let e = load_mjcf_str(
            "<mujoco><worldbody><body><geom type='box'/></body>",
            "bad.xml",
        )
        .unwrap_err();
        assert!(e.to_string().contains("bad.xml"), "{e}");
        let e = load_mjcf(Path::new("/nonexistent/robot.xml")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/robot.xml"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("not-xml.xml");
        std::fs::write(&p, "hello").unwrap();
        assert!(load_mjcf(&p)
            .unwrap_err()
            .to_string()
            .contains("not an XML"));
    }
}
