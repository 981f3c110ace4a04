//! Models opened for rendering through the session layer's registry, with the command line's
//! render options applied.

use std::path::Path;

use lucid_session::{RenderOptions, SceneModel};

use crate::cli::NerfViewArgs;

/// Opens the model file `path`, casting its rays as `args` say (an error naming the flag for
/// models without rays to cast and for values out of range).
pub fn open(path: &Path, args: &NerfViewArgs) -> anyhow::Result<Box<dyn SceneModel>> {
    let mut model = lucid_session::registry::open(path)?;
    let options = RenderOptions { pixel_rays: args.pixel_rays, step_scale: args.step_scale };
    model.set_render_options(&options).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(model)
}
