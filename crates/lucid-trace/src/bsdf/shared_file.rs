//! Data files that BSDFs borrow (measured tables, neural networks): read once per process and
//! kept, so that scenes loaded again — by benchmarks, the viewer — share them; a file changed
//! on disk (another length or modification time) is read anew.

use std::any::{Any, TypeId};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};
use std::time::SystemTime;

type Key = (TypeId, PathBuf, u64, Option<SystemTime>);

/// The `T` that `read` makes of `path`, made once per process; `io` names a failure to stat it.
pub(crate) fn load_shared<T: Any + Send + Sync, E>(
    path: &Path,
    io: impl FnOnce(std::io::Error) -> E,
    read: impl FnOnce(&Path) -> Result<T, E>,
) -> Result<&'static T, E> {
    static LOADED: OnceLock<Mutex<HashMap<Key, &'static (dyn Any + Send + Sync)>>> = OnceLock::new();
    let meta = std::fs::metadata(path).map_err(io)?;
    let canonical = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    let key = (TypeId::of::<T>(), canonical, meta.len(), meta.modified().ok());
    let loaded = LOADED.get_or_init(Default::default);
    if let Some(value) = loaded.lock().expect("file cache").get(&key).and_then(|v| v.downcast_ref::<T>()) {
        return Ok(value);
    }
    let value: &'static T = Box::leak(Box::new(read(path)?));
    loaded.lock().expect("file cache").insert(key, value);
    Ok(value)
}
