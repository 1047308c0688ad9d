//! The pieces of a rosbag 2.0 file, encoded: what the tests and the bag benchmark write their bags with. The
//! reader never uses them; they are public so that the benchmark (another crate) writes the same layout.

/// A header field `name=value`, length-prefixed.
pub fn field(name: &str, value: &[u8]) -> Vec<u8> {
    let mut f = ((name.len() + 1 + value.len()) as u32).to_le_bytes().to_vec();
    f.extend(name.as_bytes());
    f.push(b'=');
    f.extend(value);
    f
}

/// A bag record: its header's fields, then its data, each length-prefixed.
pub fn record(fields: &[(&str, &[u8])], data: &[u8]) -> Vec<u8> {
    let header: Vec<u8> = fields.iter().flat_map(|(n, v)| field(n, v)).collect();
    let mut r = (header.len() as u32).to_le_bytes().to_vec();
    r.extend(header);
    r.extend((data.len() as u32).to_le_bytes());
    r.extend(data);
    r
}

/// A ROS time (seconds, nanoseconds; u32 each) from nanoseconds.
pub fn time(ns: u64) -> Vec<u8> {
    let mut t = ((ns / 1_000_000_000) as u32).to_le_bytes().to_vec();
    t.extend(((ns % 1_000_000_000) as u32).to_le_bytes());
    t
}
