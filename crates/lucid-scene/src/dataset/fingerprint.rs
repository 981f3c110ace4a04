//! A short fingerprint of the data a model trains on, so that a resumed run can tell that it
//! is given the dataset it started on.

use super::{Dataset, Split};

impl Dataset {
    /// 16 hex digits over the training frames: each image's path and file size, its camera's
    /// size and intrinsics, and its pose. (FNV-1a: a checksum against mistakes, not a
    /// cryptographic hash, and small enough to write out here.)
    pub fn fingerprint(&self) -> String {
        let mut hash = 0xcbf2_9ce4_8422_2325u64;
        let mut eat = |bytes: &[u8]| {
            for b in bytes {
                hash ^= u64::from(*b);
                hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for frame in self.frames(Split::Train) {
            eat(frame.file_path.as_bytes());
            eat(&std::fs::metadata(&frame.image_path).map_or(0, |m| m.len()).to_le_bytes());
            let k = frame.camera.intrinsics;
            eat(&k.width.to_le_bytes());
            eat(&k.height.to_le_bytes());
            for v in [k.fx, k.fy, k.cx, k.cy].into_iter().chain(frame.camera.camera_to_world.to_cols_array()) {
                eat(&v.to_bits().to_le_bytes());
            }
        }
        format!("{hash:016x}")
    }
}
