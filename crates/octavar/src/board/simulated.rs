//! Frames of a simulated device: the exact byte stream octavar's firmware sends for given ADC codes.
//!
//! [`DeviceSim`] runs the firmware's device core, [`octavar_shared::device::Characterizer`], on the host: the
//! same accumulators, schedule, raw streaming, gap pooling and commands, with the frames numbered by one
//! [`Encoder`] into a byte vector instead of the firmware's frame queue. What it adds is the sampler's side:
//! scans gathered into blocks of [`DeviceConfig::block_scans`] and numbered by a simulated hardware index, lost
//! samples ([`DeviceSim::lose_samples`]) as a jump in that index, and a busy link
//! ([`DeviceSim::drop_next_frames`]) that drops frames so their numbers go missing.
//!
//! Tests use it to make captures with known content; `octavar demo` and the QEMU test can compare a device
//! against it.
//!
//! # Examples
//! ```
//! use octavar::board::simulated::{DeviceConfig, DeviceSim};
//! let cfg = DeviceConfig::F405;
//! let mut dev = DeviceSim::new(cfg, 0xff);
//! let mut wire = Vec::new();
//! dev.boot(&mut wire);
//! for i in 0..4_100u32 {
//!     let c = 2048 + (i % 7) as u16;
//!     dev.push_scan(&[c, c, c, c, 1900], &mut wire);
//! }
//! let stats = octavar::board::verify::verify(octavar::io::decode::CaptureReader::new(&wire[..], "sim")).unwrap();
//! assert_eq!(stats.checked, 4 * 2); // two rounds of four gyro snapshots
//! assert!(stats.passed());
//! ```

use octavar_shared::acc::Snapshot;
pub use octavar_shared::device::{ChannelSpec, DeviceConfig, STRIDE};
use octavar_shared::device::{Characterizer, FrameSink};
use octavar_shared::proto::{Command, Encoder, Frame};

/// Gyro channels of the simulated device (the board's four).
pub const GYROS: usize = 4;

/// The host's link: frames encoded and numbered into a byte vector, or dropped on request.
#[derive(Clone, Debug, Default)]
struct WireLink {
    enc: Encoder,
    pending: Vec<u8>,
    frames_dropped: u32,
    drop_next: u32,
}

impl FrameSink for WireLink {
    fn send(&mut self, frame: &Frame) {
        match self.enc.encode_to_vec(frame) {
            Ok(bytes) if self.drop_next == 0 => self.pending.extend_from_slice(&bytes),
            Ok(_) => {
                self.drop_next -= 1;
                self.frames_dropped += 1;
            }
            Err(e) => panic!("every frame fits by construction: {e}"),
        }
    }

    fn frames_dropped(&self) -> u32 {
        self.frames_dropped
    }
}

/// The simulated device: the device core, a block being filled, and the hardware scan index.
#[derive(Clone, Debug)]
pub struct DeviceSim {
    core: Characterizer<'static, GYROS>,
    link: WireLink,
    /// The scans of the block being filled.
    block: Vec<u16>,
    /// Hardware index of the block's first scan.
    block_first: u64,
    /// Hardware index of the next scan (jumps over lost samples).
    next_scan: u64,
    /// Sequence number of the next host command.
    next_command: u32,
}

impl DeviceSim {
    /// A device just booted, streaming raw codes of the channels in `raw_mask` (0: none).
    ///
    /// # Panics
    /// If the configuration is not [`DeviceConfig::is_valid`] or has other than [`GYROS`] gyros.
    pub fn new(cfg: DeviceConfig<'static>, raw_mask: u8) -> Self {
        DeviceSim {
            core: Characterizer::new(cfg, raw_mask),
            link: WireLink::default(),
            block: Vec::with_capacity(cfg.block_codes()),
            block_first: 0,
            next_scan: 0,
            next_command: 0,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &DeviceConfig<'static> {
        self.core.config()
    }

    /// Scans accumulated since boot or the last reset.
    pub fn samples(&self) -> u64 {
        self.core.samples()
    }

    /// Scans lost since boot or the last reset.
    pub fn samples_lost(&self) -> u64 {
        self.core.samples_lost()
    }

    /// The pooled snapshot of gyro `g` now.
    pub fn snapshot(&self, g: usize) -> Snapshot {
        self.core.snapshot(g)
    }

    /// The next `n` frames are dropped as if the link were busy: their sequence numbers go missing.
    pub fn drop_next_frames(&mut self, n: u32) {
        self.link.drop_next += n;
    }

    fn drain(&mut self, out: &mut Vec<u8>) {
        out.append(&mut self.link.pending);
    }

    /// Start-up: a lone delimiter and the hello frame, as the firmware starts each connection.
    pub fn boot(&mut self, out: &mut Vec<u8>) {
        // The firmware's link starts every connection with a lone delimiter, then the hello.
        out.extend_from_slice(&octavar_shared::proto::RESYNC);
        let hello = self.core.hello();
        self.link.send(&hello);
        self.drain(out);
    }

    /// Act on a host command, numbered as the host's encoder numbers them (0, 1, ...); the device acknowledges
    /// it with that number.
    pub fn command(&mut self, cmd: Command, out: &mut Vec<u8>) {
        let seq = self.next_command;
        self.next_command += 1;
        self.core.command(seq, cmd, &mut self.link);
        self.drain(out);
    }

    /// `n` samples are lost before the next scan (an overrun, a stall that outlasted the ring): the block in
    /// progress is handed on, and the hardware index jumps by `n`.
    pub fn lose_samples(&mut self, n: u64, out: &mut Vec<u8>) {
        self.flush_block(out);
        self.next_scan += n;
    }

    /// One scan: one code per channel, in channel order. Blocks are processed when full.
    ///
    /// # Panics
    /// If `scan` does not have one code per channel.
    pub fn push_scan(&mut self, scan: &[u16], out: &mut Vec<u8>) {
        assert_eq!(scan.len(), self.config().width(), "one code per channel");
        if self.block.is_empty() {
            self.block_first = self.next_scan;
        }
        self.block.extend_from_slice(scan);
        self.next_scan += 1;
        if self.block.len() == self.config().block_codes() {
            self.flush_block(out);
        }
    }

    /// Process a partially filled block now (the end of a run).
    pub fn flush_block(&mut self, out: &mut Vec<u8>) {
        if self.block.is_empty() {
            return;
        }
        self.core.feed(self.block_first, &self.block, &mut self.link);
        self.block.clear();
        self.drain(out);
    }
}

/// The whole frame stream of a device that boots with raw streaming of `raw_mask` and samples `scans`
/// (each one code per channel of `cfg`); a final partial block is processed too.
pub fn device_frames<I, S>(cfg: DeviceConfig<'static>, raw_mask: u8, scans: I) -> Vec<u8>
where
    I: IntoIterator<Item = S>,
    S: AsRef<[u16]>,
{
    let mut dev = DeviceSim::new(cfg, raw_mask);
    let mut out = Vec::new();
    dev.boot(&mut out);
    for s in scans {
        dev.push_scan(s.as_ref(), &mut out);
    }
    dev.flush_block(&mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::decode::{CaptureReader, Message};
    use octavar_shared::acc::OctaveAllan;

    fn scans(n: u32) -> impl Iterator<Item = [u16; 5]> {
        (0..n).map(|i| {
            let x = (i.wrapping_mul(2654435761) >> 22) as u16;
            [2000 + x % 97, 2000 + x % 13, 1900 + x % 31, 2048 + x % 5, 1950]
        })
    }

    #[test]
    fn frame_order_is_the_firmwares() {
        let wire = device_frames(DeviceConfig::F405, 0x1f, scans(2100));
        let kinds: Vec<&str> = CaptureReader::new(&wire[..], "sim")
            .map(|d| match d.unwrap().message {
                Message::Hello(_) => "hello",
                Message::Samples(_) => "samples",
                Message::Snapshot(_) => "snapshot",
                Message::Status(_) => "status",
                Message::Estimate(_) => "estimate",
                _ => "other",
            })
            .collect();
        // 2100 scans: blocks of 128, the round falls inside the 16th block (after its raw frames).
        assert_eq!(kinds[0], "hello");
        let first_snapshot = kinds.iter().position(|k| *k == "snapshot").unwrap();
        assert_eq!(first_snapshot, 1 + 16 * 4);
        assert_eq!(
            &kinds[first_snapshot..first_snapshot + 6],
            ["snapshot", "snapshot", "snapshot", "snapshot", "estimate", "status"]
        );
        // The partial last block (52 scans) still streams its raw codes.
        assert_eq!(kinds.len(), 1 + 64 + 6 + 2);
    }

    #[test]
    fn a_reset_restarts_the_raw_index_as_the_firmware_does() {
        let mut dev = DeviceSim::new(DeviceConfig::F405, 0x01);
        let mut out = Vec::new();
        dev.boot(&mut out);
        let block = DeviceConfig::F405.block_scans as u64;
        for s in scans(3 * block as u32) {
            dev.push_scan(s.as_ref(), &mut out);
        }
        dev.command(Command::Reset, &mut out);
        dev.lose_samples(5, &mut out);
        for s in scans(2 * block as u32) {
            dev.push_scan(s.as_ref(), &mut out);
        }
        let firsts: Vec<u64> = CaptureReader::new(&out[..], "sim")
            .filter_map(|d| match d.unwrap().message {
                Message::Samples(s) => Some(s.first_sample),
                _ => None,
            })
            .collect();
        let per = DeviceConfig::F405.raw_scans_per_frame as u64;
        // Before the reset: 0, per, ... ; after it the index starts at 0 again (the lost samples before the
        // session's first block are not a gap within the session).
        let after: Vec<u64> = firsts.iter().copied().skip((3 * block / per) as usize).collect();
        assert_eq!(firsts[0], 0);
        assert_eq!(after[0], 0, "{firsts:?}");
        assert_eq!(after[1], per, "{firsts:?}");
        assert_eq!(dev.samples(), 2 * block);
    }

    #[test]
    fn device_snapshot_is_the_plain_accumulator_without_gaps() {
        let mut dev = DeviceSim::new(DeviceConfig::F405, 0);
        let mut out = Vec::new();
        let mut acc = OctaveAllan::<8>::new();
        for s in scans(5000) {
            dev.push_scan(&s, &mut out);
            acc.push(s[2]);
        }
        dev.flush_block(&mut out);
        assert_eq!(dev.snapshot(2), acc.snapshot());
    }
}
