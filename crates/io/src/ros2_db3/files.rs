//! The SQLite files of a bag: the file given, or the `.db3` files of a bag directory (rosbag2 writes one folder
//! with `metadata.yaml` and the storage files, split as `NAME_0.db3`, `NAME_1.db3`, ... when the bag is split by
//! size or duration) in the order of their split index. A bag recorded with rosbag2's file compression holds
//! `NAME_0.db3.zstd`, ... instead; those are read the same way.

use std::path::{Path, PathBuf};

use crate::imu_topic::BagError;

/// Whether `dir` is a rosbag2 directory in SQLite storage: `metadata.yaml` and at least one `.db3` (or
/// `.db3.zstd`) file.
pub fn is_db3_dir(dir: &Path) -> bool {
    dir.join("metadata.yaml").is_file() && db3_files(dir).is_ok_and(|f| !f.is_empty())
}

/// The `.db3` files to read for `path`: itself, or those of the directory in split order.
///
/// # Errors
/// A directory that cannot be listed or holds no `.db3` file.
pub(super) fn bag_files(path: &Path) -> Result<Vec<PathBuf>, BagError> {
    if !path.is_dir() {
        return Ok(vec![path.to_path_buf()]);
    }
    let files = db3_files(path).map_err(|err| BagError::Io { path: path.display().to_string(), err })?;
    if files.is_empty() {
        return Err(BagError::EmptyBagDir { path: path.display().to_string() });
    }
    Ok(files)
}

/// Whether the name at `path` is that of a storage file: `NAME.db3` or, compressed, `NAME.db3.zstd`.
pub fn is_db3_name(path: &Path) -> bool {
    let name = path.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    name.ends_with(".db3") || name.ends_with(".db3.zstd")
}

/// The `.db3` (and `.db3.zstd`) files of `dir`, ordered by the split index their names end with (`bag_2` before
/// `bag_10`), then by name.
fn db3_files(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir)? {
        let p = entry?.path();
        if p.is_file() && is_db3_name(&p) {
            files.push(p);
        }
    }
    files.sort_by_key(|p| split_key(p));
    Ok(files)
}

/// A file's place among the splits: its stem (the name less `.db3` or `.db3.zstd`) without the trailing digits,
/// the number they make, the name.
fn split_key(p: &Path) -> (String, u64, String) {
    let name = p.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let lower = name.to_ascii_lowercase();
    let ext = [".db3.zstd", ".db3"].into_iter().find(|e| lower.ends_with(e)).map_or(0, str::len);
    let stem = name[..name.len() - ext].to_string();
    let digits = stem.bytes().rev().take_while(u8::is_ascii_digit).count().min(18);
    let (head, tail) = stem.split_at(stem.len() - digits);
    (head.to_string(), tail.parse().unwrap_or(0), stem.clone())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_sort_by_their_index() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["bag_10.db3", "bag_2.db3.zstd", "bag_0.db3", "notes.txt", "bag_1.db3-shm"] {
            std::fs::write(dir.path().join(name), b"").unwrap();
        }
        assert!(!is_db3_dir(dir.path()));
        std::fs::write(dir.path().join("metadata.yaml"), b"rosbag2_bagfile_information:\n").unwrap();
        assert!(is_db3_dir(dir.path()));
        let names: Vec<String> = bag_files(dir.path())
            .unwrap()
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["bag_0.db3", "bag_2.db3.zstd", "bag_10.db3"]);
        let empty = tempfile::tempdir().unwrap();
        assert!(matches!(bag_files(empty.path()), Err(BagError::EmptyBagDir { .. })));
    }
}
