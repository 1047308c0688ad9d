//! A model of the sampling converter for the host tests: TIM3 triggering at the sample rate, TIM5 counting the
//! triggers (32 bits, wrapping), ADC1's scan sequencer writing one code per conversion, DMA2 stream 0 writing
//! them into a ring of `CODES` half-words in circular mode with NDTR counting down, and the CPU's time, which
//! every register access advances. It is deterministic (one seed), needs no allocation, and implements
//! [`ConverterRegs`], so [`super::Converter`] and the sampler's poll run on it unchanged.
//!
//! Every code the model converts identifies its scan and channel ([`code`]): a test compares each block handed
//! on with what the model converted for that index, and tells a stale code (an older lap), a rotated one (another
//! channel) or a misplaced one (another scan) at once.
//!
//! The rules it holds the driver to (RM0090 section 10.3's stream configuration procedure, section 10.5's
//! registers and section 13.8.1; a break counts in [`ModelLog::violations`]): the stream's configuration and NDTR
//! are written only while it is disabled, it is enabled only with its flags clear (disabling it by software sets
//! TCIF) and only as the ring (peripheral to memory, circular, half-words, NDTR the ring's length), the ADC's DMA
//! requests are re-enabled only once OVR is clear, and the ADC is triggered only after its stabilisation time. What the hardware does on its own: triggers are ignored while OVR is set; an overrun stops the DMA
//! requests until DMA is cleared and set again in ADC_CR2 with OVR clear; the sequencer resumes where it stopped
//! unless ADON is cleared, which resets it to the first channel; a conversion whose request the DMA does not
//! serve leaves its code in ADC_DR, and the next conversion overruns.
//!
//! Faults ([`Fault`]) hit the next DMA transfer, when injected one by one ([`ScanModel::inject`]) or arriving at
//! random times ([`ScanModel::random_faults`]); interrupts can delay the CPU at any register access outside a
//! critical section ([`ScanModel::interrupts`]); [`ScanModel::cpu_away`] is the CPU busy elsewhere (other tasks,
//! a flash stall).

use super::{adc_cr2, adc_sr, dma_cr, dma_flags, ConverterRegs, Failure};
use crate::sim::rng::SimRng;

/// The code the model's ADC converts for channel (sequencer rank) `channel` of scan `scan`: a 16-bit hash of
/// both, so a code in the wrong place is told from the right one.
pub const fn code(scan: u64, channel: usize) -> u16 {
    let mut z = scan.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (channel as u64 + 1).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 31)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 29;
    (z >> 48) as u16
}

/// The model's clocks, in ticks of TIM3's counter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timing {
    /// Ticks between triggers (ARR + 1).
    pub period_ticks: u32,
    /// Ticks per conversion (sampling and conversion time).
    pub conversion_ticks: u32,
    /// Ticks from a trigger to the start of its first conversion.
    pub latency_ticks: u32,
    /// Ticks the ADC needs after ADON before a trigger (tSTAB).
    pub stabilisation_ticks: u32,
    /// Ticks of CPU time per register access.
    pub access_ticks: u32,
    /// Ticks of CPU time per code read from the ring.
    pub code_read_ticks: u32,
}

impl Timing {
    /// The board's: TIM3 at 84 MHz triggering at 2 kHz; ADC1 at 21 MHz (4 ticks a cycle), 480 sampling and 12
    /// conversion cycles per channel, a trigger latency of 3 ADC cycles, tSTAB 3 us (the datasheet's maximum);
    /// about 8 CPU cycles (168 MHz) per peripheral access and 2 per code copied.
    pub const F405: Timing = Timing {
        period_ticks: 42_000,
        conversion_ticks: (480 + 12) * 4,
        latency_ticks: 3 * 4,
        stabilisation_ticks: 3 * 84,
        access_ticks: 4,
        code_read_ticks: 1,
    };

    /// Ticks from a trigger to the end of its scan's last conversion.
    pub const fn scan_ticks(&self, channels: usize) -> u32 {
        self.latency_ticks + channels as u32 * self.conversion_ticks
    }
}

/// A fault of the converter. Each hits the next DMA transfer after it arrives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// The ADC overruns: the code is lost, OVR is set, the scan stops and so do the DMA requests; the sequencer
    /// stays where it stopped.
    Overrun,
    /// The DMA loses the request without a flag: one code is missing and the ring's channel order rotates.
    DroppedRequest,
    /// A direct-mode error (DMEIF): the code is lost, the stream goes on.
    DirectModeError,
    /// A transfer error (TEIF): the code is lost and the hardware disables the stream; the ADC overruns at the
    /// conversion after next.
    TransferError,
    /// The stream stops without a flag before the transfer; the ADC overruns at the next conversion.
    StreamStop,
}

impl Fault {
    /// Every kind, in [`ModelLog::faults`]' order.
    pub const ALL: [Fault; 5] =
        [Fault::Overrun, Fault::DroppedRequest, Fault::DirectModeError, Fault::TransferError, Fault::StreamStop];

    /// Its place in [`Fault::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }
}

/// What happened in the model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ModelLog {
    /// Triggers (scans started).
    pub scans: u64,
    /// Conversions completed.
    pub conversions: u64,
    /// Codes the DMA wrote into the ring.
    pub codes_written: u64,
    /// Faults that hit a transfer, by kind ([`Fault::ALL`]'s order).
    pub faults: [u64; 5],
    /// Faults that hit between a read of ADC_SR (a check) and the end of a copy from the ring after it.
    pub window_faults: u64,
    /// Failures the driver found (and recovered from).
    pub failures: u64,
    /// Failures found with OVR set.
    pub failed_overrun: u64,
    /// Failures found with TEIF set.
    pub failed_transfer_error: u64,
    /// Failures found with DMEIF set.
    pub failed_direct_mode_error: u64,
    /// Failures found with the stream disabled.
    pub failed_stream_off: u64,
    /// Failures found on the DMA's position alone.
    pub failed_position: u64,
    /// Rule breaks by the driver: 0 for a correct one.
    pub violations: u32,
    /// The last rule broken.
    pub last_violation: &'static str,
}

impl ModelLog {
    /// Faults of every kind.
    pub fn total_faults(&self) -> u64 {
        self.faults.iter().sum()
    }
}

/// A scan in progress.
#[derive(Clone, Copy, Debug)]
struct Scan {
    index: u64,
    done: usize,
    next_at: u64,
}

/// Faults waiting for the next transfer (a small queue: faults arriving while it is full are dropped).
#[derive(Clone, Copy, Debug, Default)]
struct Pending {
    queue: [Option<Fault>; 8],
    head: usize,
    len: usize,
}

impl Pending {
    fn push(&mut self, f: Fault) {
        if self.len < self.queue.len() {
            self.queue[(self.head + self.len) % self.queue.len()] = Some(f);
            self.len += 1;
        }
    }

    fn pop(&mut self) -> Option<Fault> {
        if self.len == 0 {
            return None;
        }
        let f = self.queue[self.head].take();
        self.head = (self.head + 1) % self.queue.len();
        self.len -= 1;
        f
    }
}

/// The converter's hardware with a ring of `CODES` half-words (see the module docs).
pub struct ScanModel<const CODES: usize> {
    channels: usize,
    timing: Timing,
    /// CPU time, ticks.
    now: u64,
    tim3_running: bool,
    next_trigger: u64,
    tim5_start: u32,
    adc_cr2: u32,
    adc_sr: u32,
    adon_at: u64,
    /// The sequencer's next rank.
    rank: usize,
    scan: Option<Scan>,
    /// ADC_DR holds a code no transfer took.
    dr_unread: bool,
    /// DMA requests stopped by an overrun.
    requests_blocked: bool,
    dma_cr: u32,
    ndtr: u32,
    ndtr_reload: u32,
    dma_flags: u32,
    /// Reads of DMA_SxCR that still show EN after software cleared it.
    en_reads: u8,
    ring: [u16; CODES],
    rng: SimRng,
    pending: Pending,
    fault_gap_ticks: u64,
    fault_weights: [u32; 5],
    next_fault_at: u64,
    interrupt_chance: u32,
    interrupt_max_ticks: u32,
    masked: bool,
    faults_since_check: u64,
    /// What happened.
    pub log: ModelLog,
}

impl<const CODES: usize> ScanModel<CODES> {
    /// The converter after reset with `channels` per scan, TIM5 holding `tim5_start` and TIM3 stopped; `seed`
    /// fixes every random choice.
    ///
    /// # Panics
    /// If the ring is not a whole number of scans, or a scan does not fit a trigger period.
    pub fn new(channels: usize, timing: Timing, tim5_start: u32, seed: u64) -> Self {
        assert!(channels > 0 && CODES.is_multiple_of(channels) && CODES <= u16::MAX as usize);
        assert!(timing.scan_ticks(channels) < timing.period_ticks);
        ScanModel {
            channels,
            timing,
            now: 0,
            tim3_running: false,
            next_trigger: u64::MAX,
            tim5_start,
            adc_cr2: 0,
            adc_sr: 0,
            adon_at: 0,
            rank: 0,
            scan: None,
            dr_unread: false,
            requests_blocked: false,
            dma_cr: 0,
            ndtr: 0,
            ndtr_reload: 0,
            dma_flags: 0,
            en_reads: 0,
            ring: [0; CODES],
            rng: SimRng::new(seed),
            pending: Pending::default(),
            fault_gap_ticks: 0,
            fault_weights: [1; 5],
            next_fault_at: u64::MAX,
            interrupt_chance: 0,
            interrupt_max_ticks: 0,
            masked: false,
            faults_since_check: 0,
            log: ModelLog::default(),
        }
    }

    /// Start TIM3 (the firmware's last configuration step): its first trigger comes a period later.
    pub fn start_tim3(&mut self) {
        self.tim3_running = true;
        self.next_trigger = self.now + u64::from(self.timing.period_ticks);
    }

    /// The fault hits the next DMA transfer (after any injected before it).
    pub fn inject(&mut self, fault: Fault) {
        self.pending.push(fault);
    }

    /// Faults arrive at random, uniformly 1 to `2 * mean_gap_ticks` apart (0: none), of a kind drawn with
    /// `weights` ([`Fault::ALL`]'s order).
    pub fn random_faults(&mut self, mean_gap_ticks: u64, weights: [u32; 5]) {
        assert!(weights.iter().any(|&w| w > 0));
        self.fault_gap_ticks = mean_gap_ticks;
        self.fault_weights = weights;
        self.next_fault_at = if mean_gap_ticks == 0 { u64::MAX } else { self.now + self.fault_gap() };
    }

    /// An interrupt delays the CPU by up to `max_ticks` at a register access (or a code read) outside a critical
    /// section, with probability `per_65536` / 65536.
    pub fn interrupts(&mut self, per_65536: u32, max_ticks: u32) {
        self.interrupt_chance = per_65536;
        self.interrupt_max_ticks = max_ticks.max(1);
    }

    /// The CPU is busy elsewhere for `ticks` (another task, a flash stall): the hardware runs on.
    pub fn cpu_away(&mut self, ticks: u64) {
        self.now += ticks;
        self.run_to(self.now);
    }

    /// The CPU waits until the scan with hardware index `index` has started.
    pub fn run_until_started(&mut self, index: u64) {
        while self.scans_started() <= index {
            self.cpu_away(self.next_trigger - self.now);
        }
    }

    /// Hardware index of the next scan to start (TIM5's count, extended): every scan below it has started.
    pub fn scans_started(&self) -> u64 {
        u64::from(self.tim5_start) + self.log.scans
    }

    /// CPU time, ticks.
    pub fn now(&self) -> u64 {
        self.now
    }

    /// Codes the DMA has written since it was last armed, modulo the ring, as NDTR shows it.
    pub fn dma_position(&self) -> usize {
        (CODES - self.ndtr as usize % CODES) % CODES
    }

    /// Whether the stream is enabled.
    pub fn stream_enabled(&self) -> bool {
        self.dma_cr & dma_cr::EN != 0
    }

    fn fault_gap(&mut self) -> u64 {
        1 + self.rng.next_u64() % (2 * self.fault_gap_ticks)
    }

    fn violation(&mut self, rule: &'static str) {
        self.log.violations += 1;
        self.log.last_violation = rule;
    }

    /// The CPU spends `ticks` (and an interrupt's time, perhaps).
    fn cpu(&mut self, ticks: u32) {
        let mut t = u64::from(ticks);
        if !self.masked
            && self.interrupt_chance > 0
            && (self.rng.next_u64() % 65_536) < u64::from(self.interrupt_chance)
        {
            t += self.rng.next_u64() % u64::from(self.interrupt_max_ticks);
        }
        self.now += t;
        self.run_to(self.now);
    }

    fn access(&mut self) {
        self.cpu(self.timing.access_ticks);
    }

    /// Run the hardware up to `t`.
    fn run_to(&mut self, t: u64) {
        let cpu = self.now;
        loop {
            let conversion = self.scan.map_or(u64::MAX, |s| s.next_at);
            let trigger = if self.tim3_running { self.next_trigger } else { u64::MAX };
            let next = conversion.min(trigger).min(self.next_fault_at);
            if next > t {
                break;
            }
            self.now = next;
            if next == conversion {
                self.convert();
            } else if next == trigger {
                self.trigger();
            } else {
                let kind = self.random_kind();
                self.pending.push(kind);
                self.next_fault_at = next + self.fault_gap();
            }
        }
        self.now = cpu.max(t);
    }

    fn random_kind(&mut self) -> Fault {
        let total: u32 = self.fault_weights.iter().sum();
        let mut r = (self.rng.next_u64() % u64::from(total)) as u32;
        for (kind, &w) in Fault::ALL.iter().zip(&self.fault_weights) {
            if r < w {
                return *kind;
            }
            r -= w;
        }
        Fault::Overrun
    }

    fn trigger(&mut self) {
        let index = self.scans_started();
        self.log.scans += 1;
        self.next_trigger += u64::from(self.timing.period_ticks);
        let cr2 = self.adc_cr2;
        let armed = cr2 & adc_cr2::ADON != 0
            && cr2 & adc_cr2::EXTEN_MASK == adc_cr2::EXTEN_RISING
            && cr2 & adc_cr2::EXTSEL_MASK == adc_cr2::EXTSEL_TIM3_TRGO;
        if !armed || self.adc_sr & adc_sr::OVR != 0 {
            return;
        }
        if self.now < self.adon_at + u64::from(self.timing.stabilisation_ticks) {
            self.violation("the ADC was triggered before its stabilisation time");
        }
        if self.scan.is_some() {
            self.violation("a trigger came during a scan");
            return;
        }
        self.adc_sr |= adc_sr::STRT;
        let first = self.now + u64::from(self.timing.latency_ticks + self.timing.conversion_ticks);
        self.scan = Some(Scan { index, done: 0, next_at: first });
    }

    fn convert(&mut self) {
        let Some(mut scan) = self.scan else { return };
        let value = code(scan.index, self.rank);
        self.rank = (self.rank + 1) % self.channels;
        self.log.conversions += 1;
        scan.done += 1;
        scan.next_at += u64::from(self.timing.conversion_ticks);
        self.scan = (scan.done < self.channels).then_some(scan);
        self.adc_sr |= adc_sr::EOC;
        if self.adc_cr2 & adc_cr2::DMA == 0 {
            return;
        }
        if self.dr_unread {
            return self.overrun();
        }
        if self.requests_blocked || self.dma_cr & dma_cr::EN == 0 {
            self.dr_unread = true;
            return;
        }
        if let Some(fault) = self.pending.pop() {
            self.log.faults[fault.index()] += 1;
            self.faults_since_check += 1;
            match fault {
                Fault::Overrun => return self.overrun(),
                Fault::DroppedRequest => return,
                Fault::DirectModeError => {
                    self.dma_flags |= dma_flags::DMEIF;
                    return;
                }
                Fault::TransferError => {
                    self.dma_flags |= dma_flags::TEIF;
                    self.dma_cr &= !dma_cr::EN;
                    return;
                }
                Fault::StreamStop => {
                    self.dma_cr &= !dma_cr::EN;
                    self.dr_unread = true;
                    return;
                }
            }
        }
        let at = CODES - self.ndtr as usize;
        self.ring[at] = value;
        self.log.codes_written += 1;
        self.ndtr -= 1;
        if self.ndtr == self.ndtr_reload / 2 {
            self.dma_flags |= dma_flags::HTIF;
        }
        if self.ndtr == 0 {
            self.ndtr = self.ndtr_reload;
            self.dma_flags |= dma_flags::TCIF;
        }
    }

    /// A code was lost: OVR, the scan aborted, the DMA requests stopped.
    fn overrun(&mut self) {
        self.adc_sr |= adc_sr::OVR;
        self.scan = None;
        self.requests_blocked = true;
    }
}

impl<const CODES: usize> ConverterRegs for ScanModel<CODES> {
    fn adc_sr(&mut self) -> u32 {
        self.access();
        self.faults_since_check = 0;
        self.adc_sr
    }

    fn set_adc_sr(&mut self, value: u32) {
        self.access();
        self.adc_sr &= value | !adc_sr::FLAGS;
    }

    fn adc_cr2(&mut self) -> u32 {
        self.access();
        self.adc_cr2
    }

    fn set_adc_cr2(&mut self, value: u32) {
        self.access();
        let old = self.adc_cr2;
        if old & adc_cr2::ADON != 0 && value & adc_cr2::ADON == 0 {
            // Switched off: the conversion stops and the sequencer goes back to its first rank.
            self.scan = None;
            self.rank = 0;
            self.dr_unread = false;
        }
        if old & adc_cr2::ADON == 0 && value & adc_cr2::ADON != 0 {
            self.adon_at = self.now;
        }
        if old & adc_cr2::DMA == 0 && value & adc_cr2::DMA != 0 {
            if self.adc_sr & adc_sr::OVR != 0 {
                self.violation("ADC_CR2.DMA set again with OVR still set");
            } else {
                self.requests_blocked = false;
            }
        }
        self.adc_cr2 = value;
    }

    fn dma_cr(&mut self) -> u32 {
        self.access();
        if self.en_reads > 0 {
            self.en_reads -= 1;
            return self.dma_cr | dma_cr::EN;
        }
        self.dma_cr
    }

    fn set_dma_cr(&mut self, value: u32) {
        self.access();
        if self.dma_cr & dma_cr::EN != 0 {
            if (value ^ self.dma_cr) & !dma_cr::EN != 0 {
                self.violation("DMA_SxCR's configuration written while the stream is enabled");
            }
            if value & dma_cr::EN == 0 {
                // The stream finishes its current transfer, then stops and sets TCIF.
                self.dma_cr &= !dma_cr::EN;
                self.en_reads = 1;
                self.dma_flags |= dma_flags::TCIF;
            }
            return;
        }
        self.dma_cr = value & !dma_cr::EN;
        if value & dma_cr::EN == 0 {
            return;
        }
        if self.dma_flags != 0 {
            return self.violation("the stream was enabled with its flags set");
        }
        let config = dma_cr::DIR_MASK
            | dma_cr::CIRC
            | dma_cr::PINC
            | dma_cr::MINC
            | dma_cr::PSIZE_MASK
            | dma_cr::MSIZE_MASK
            | dma_cr::CHSEL_MASK;
        if value & config != dma_cr::RING & config {
            return self.violation("the stream was enabled configured other than as the ring");
        }
        if self.ndtr as usize != CODES {
            return self.violation("the stream was enabled with NDTR other than the ring's length");
        }
        self.dma_cr |= dma_cr::EN;
    }

    fn dma_ndtr(&mut self) -> u32 {
        self.access();
        self.ndtr
    }

    fn set_dma_ndtr(&mut self, value: u32) {
        self.access();
        if self.dma_cr & dma_cr::EN != 0 {
            return self.violation("NDTR written while the stream is enabled");
        }
        self.ndtr = value & 0xFFFF;
        self.ndtr_reload = self.ndtr;
    }

    fn dma_flags(&mut self) -> u32 {
        self.access();
        self.dma_flags
    }

    fn clear_dma_flags(&mut self, flags: u32) {
        self.access();
        self.dma_flags &= !flags;
    }

    fn tim5_cnt(&mut self) -> u32 {
        self.access();
        self.scans_started() as u32
    }

    fn tim3_cnt(&mut self) -> u32 {
        self.access();
        if !self.tim3_running {
            return 0;
        }
        (u64::from(self.timing.period_ticks) - (self.next_trigger - self.now)) as u32
    }

    fn read_ring(&mut self, from: usize, out: &mut [u16]) {
        for (i, code) in out.iter_mut().enumerate() {
            self.cpu(self.timing.code_read_ticks);
            *code = self.ring[from + i];
        }
        self.log.window_faults += self.faults_since_check;
        self.faults_since_check = 0;
    }

    fn delay_ticks(&mut self, ticks: u32) {
        self.cpu(ticks);
    }

    fn critical<T>(&mut self, f: impl FnOnce(&mut Self) -> T) -> T {
        self.masked = true;
        let r = f(self);
        self.masked = false;
        r
    }

    fn failed(&mut self, failure: &Failure) {
        let log = &mut self.log;
        log.failures += 1;
        log.failed_overrun += u64::from(failure.overrun);
        log.failed_transfer_error += u64::from(failure.transfer_error);
        log.failed_direct_mode_error += u64::from(failure.direct_mode_error);
        log.failed_stream_off += u64::from(failure.stream_off);
        log.failed_position += u64::from(failure.position);
    }
}
