//! Edits of how the scene looks and runs: lights, picture size and
//! background, frame rate and duration (the camera is set whole).

use csrbf_anim::{LightFile, SceneFile};

use crate::EditError;

/// The directional lights (none: the renderer's default key and fill).
pub(super) fn set_lights(file: &mut SceneFile, lights: &[LightFile]) -> Result<(), EditError> {
    for (i, l) in lights.iter().enumerate() {
        let d = l.direction;
        if d.iter().any(|c| !c.is_finite()) || d.iter().all(|c| *c == 0.0) {
            return Err(EditError::Invalid(format!(
                "light {i}: its direction must be finite and not zero, got {d:?}"
            )));
        }
        if l.color.iter().any(|c| !c.is_finite() || *c < 0.0)
            || !l.intensity.is_finite()
            || l.intensity < 0.0
        {
            return Err(EditError::Invalid(format!(
                "light {i}: colour and intensity must be finite and >= 0, got {:?} and {}",
                l.color, l.intensity
            )));
        }
    }
    file.lights = lights.to_vec();
    Ok(())
}

/// The picture size and background colour (linear RGB in [0, 1]).
pub(super) fn set_look(
    file: &mut SceneFile,
    size: [u32; 2],
    background: [f32; 3],
) -> Result<(), EditError> {
    if background.iter().any(|c| !(0.0..=1.0).contains(c)) {
        return Err(EditError::Invalid(format!(
            "background colour must be within [0, 1], got {background:?}"
        )));
    }
    file.size = size;
    file.background = background;
    Ok(())
}

/// The frame rate and duration; the scene cannot end before its last key.
pub(super) fn set_timing(file: &mut SceneFile, fps: f64, duration: f64) -> Result<(), EditError> {
    if !(fps > 0.0 && fps.is_finite() && duration > 0.0 && duration.is_finite()) {
        return Err(EditError::Invalid(format!(
            "fps and duration must be numbers > 0, got {fps} and {duration}"
        )));
    }
    let last = file
        .objects
        .iter()
        .flat_map(|o| {
            o.trajectory
                .iter()
                .map(|k| k.time)
                .chain(o.orientation.iter().map(|k| k.time))
                .chain(
                    o.parts
                        .iter()
                        .flat_map(|p| &p.deformations)
                        .flat_map(|d| d.phase.iter().map(|k| k.time)),
                )
        })
        .fold(0.0, f64::max);
    if duration < last {
        return Err(EditError::Invalid(format!(
            "a key is at {last} s: the scene cannot end before it"
        )));
    }
    file.fps = fps;
    file.duration = duration;
    Ok(())
}
