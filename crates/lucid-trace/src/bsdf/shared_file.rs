//! Data that BSDFs borrow (measured tables, neural networks): made once per process and kept,
//! so that scenes loaded again — by benchmarks, the viewer — share it. A file changed on disk
//! (another length or modification time) is read anew; data without a file (built-in assets,
//! tables tabulated from a scene's material) is keyed by a name.

use std::any::{Any, TypeId};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};
use std::time::SystemTime;

#[derive(Clone, PartialEq, Eq, Hash)]
enum Source {
    File(PathBuf, u64, Option<SystemTime>),
    Named(String),
}

type Cache = Mutex<HashMap<(TypeId, Source), &'static (dyn Any + Send + Sync)>>;

fn cached<T: Any + Send + Sync, E>(source: Source, make: impl FnOnce() -> Result<T, E>) -> Result<&'static T, E> {
    static LOADED: OnceLock<Cache> = OnceLock::new();
    let key = (TypeId::of::<T>(), source);
    let loaded = LOADED.get_or_init(Default::default);
    if let Some(value) = loaded.lock().expect("data cache").get(&key).and_then(|v| v.downcast_ref::<T>()) {
        return Ok(value);
    }
    let value: &'static T = Box::leak(Box::new(make()?));
    loaded.lock().expect("data cache").insert(key, value);
    Ok(value)
}

/// The `T` that `read` makes of `path`, made once per process; `io` names a failure to stat it.
pub(crate) fn load_shared<T: Any + Send + Sync, E>(
    path: &Path,
    io: impl FnOnce(std::io::Error) -> E,
    read: impl FnOnce(&Path) -> Result<T, E>,
) -> Result<&'static T, E> {
    let meta = std::fs::metadata(path).map_err(io)?;
    let canonical = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    cached(Source::File(canonical, meta.len(), meta.modified().ok()), || read(path))
}

/// The `T` that `make` makes for `name`, made once per process.
pub(crate) fn load_named<T: Any + Send + Sync, E>(
    name: &str,
    make: impl FnOnce() -> Result<T, E>,
) -> Result<&'static T, E> {
    cached(Source::Named(name.to_string()), make)
}
