//! The storage files of a rosbag2 bag folder: rosbag2 writes one folder with `metadata.yaml` and the storage files,
//! split as `NAME_0.db3`, `NAME_1.db3`, ... (or `.mcap`) when the bag is split by size or duration, and with its
//! file compression `NAME_0.db3.zstd` (or `.mcap.zstd`). The files are read in the order of their split index.

use std::path::{Path, PathBuf};

use crate::imu_topic::BagError;

/// A rosbag2 storage plugin, by the file names it writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Storage {
    /// `sqlite3`: `.db3` files.
    Sqlite,
    /// `mcap`: `.mcap` files.
    Mcap,
}

impl Storage {
    /// The endings of this storage's file names, compressed first (both lower case).
    fn endings(self) -> [&'static str; 2] {
        match self {
            Storage::Sqlite => [".db3.zstd", ".db3"],
            Storage::Mcap => [".mcap.zstd", ".mcap"],
        }
    }

    /// How long the ending of `name` is, when it is one of this storage's.
    fn ending_len(self, name: &str) -> Option<usize> {
        let lower = name.to_ascii_lowercase();
        self.endings().into_iter().find(|e| lower.ends_with(e)).map(str::len)
    }

    /// Whether the name at `path` is that of one of this storage's files (`NAME.db3` or `NAME.db3.zstd`, ...).
    pub fn is_file_name(self, path: &Path) -> bool {
        path.file_name().is_some_and(|n| self.ending_len(&n.to_string_lossy()).is_some())
    }

    /// Whether `dir` is a rosbag2 folder in this storage: `metadata.yaml` and at least one storage file.
    pub fn is_bag_dir(self, dir: &Path) -> bool {
        dir.join("metadata.yaml").is_file() && self.files_of(dir).is_ok_and(|f| !f.is_empty())
    }

    /// The storage files to read for `path`: itself, or those of the folder in split order.
    ///
    /// # Errors
    /// A folder that cannot be listed or holds no storage file.
    pub(crate) fn bag_files(self, path: &Path) -> Result<Vec<PathBuf>, BagError> {
        if !path.is_dir() {
            return Ok(vec![path.to_path_buf()]);
        }
        let files = self.files_of(path).map_err(|err| BagError::Io { path: path.display().to_string(), err })?;
        if files.is_empty() {
            let wanted = self.endings().join(" or ");
            return Err(BagError::EmptyBagDir { path: path.display().to_string(), wanted });
        }
        Ok(files)
    }

    /// The storage files of `dir`, ordered by the split index their names end with (`bag_2` before `bag_10`),
    /// then by name.
    fn files_of(self, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
        let mut files = Vec::new();
        for entry in std::fs::read_dir(dir)? {
            let p = entry?.path();
            if p.is_file() && self.is_file_name(&p) {
                files.push(p);
            }
        }
        files.sort_by_key(|p| self.split_key(p));
        Ok(files)
    }

    /// A file's place among the splits: its name less the storage's ending, without the trailing digits; the
    /// number they make; the name.
    fn split_key(self, p: &Path) -> (String, u64, String) {
        let name = p.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let stem = &name[..name.len() - self.ending_len(&name).unwrap_or(0)];
        let digits = stem.bytes().rev().take_while(u8::is_ascii_digit).count().min(18);
        let (head, tail) = stem.split_at(stem.len() - digits);
        (head.to_string(), tail.parse().unwrap_or(0), name.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_sort_by_their_index() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["bag_10.db3", "bag_2.db3.zstd", "bag_0.db3", "notes.txt", "bag_1.db3-shm", "bag_0.mcap"] {
            std::fs::write(dir.path().join(name), b"").unwrap();
        }
        assert!(!Storage::Sqlite.is_bag_dir(dir.path()));
        std::fs::write(dir.path().join("metadata.yaml"), b"rosbag2_bagfile_information:\n").unwrap();
        assert!(Storage::Sqlite.is_bag_dir(dir.path()) && Storage::Mcap.is_bag_dir(dir.path()));
        let names = |s: Storage| -> Vec<String> {
            let files = s.bag_files(dir.path()).unwrap();
            files.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect()
        };
        assert_eq!(names(Storage::Sqlite), ["bag_0.db3", "bag_2.db3.zstd", "bag_10.db3"]);
        assert_eq!(names(Storage::Mcap), ["bag_0.mcap"]);
        let empty = tempfile::tempdir().unwrap();
        let err = Storage::Mcap.bag_files(empty.path()).unwrap_err();
        assert!(matches!(err, BagError::EmptyBagDir { .. }) && err.to_string().contains(".mcap"), "{err}");
    }
}
