//! The converter's decisions and the sampler's poll against the model of ADC1, DMA2 stream 0, TIM3 and TIM5, with
//! the board's dimensions: five channels, blocks of 128 scans, a ring of 16 blocks.
//!
//! Truth is the model's: every code handed on must be the one it converted for that scan and channel, and every
//! scan it started must be handed on or counted lost, each gap exactly where the hardware index jumps.

use super::model::{code, Fault, ScanModel, Timing};
use super::*;
use crate::device::{BlockSink, ReadyBlock, RingReader, Sampler, SamplerEvent, ScanRing};
use crate::sim::rng::SimRng;

const C: usize = 5;
const BLOCK: usize = 128;
/// The firmware's ring: 16 blocks, 1.024 s at 2 kS/s.
const RING: usize = 16 * BLOCK;
const CODES: usize = RING * C;
const N: usize = BLOCK * C;
const PERIOD: u64 = Timing::F405.period_ticks as u64;
/// The firmware's poll period, 16 ms.
const POLL_TICKS: u64 = 32 * PERIOD;

type Model = ScanModel<CODES>;
type Ring = Converter<Model>;

fn config() -> ConverterConfig {
    let t = Timing::F405;
    ConverterConfig {
        channels: C,
        ring_scans: RING,
        settled_ticks: settled_ticks(t.scan_ticks(C), t.period_ticks),
        // The board waits 4 us for tSTAB's 3.
        stabilisation_ticks: 4 * 84,
    }
}

/// The converter started as the firmware starts it (TIM3 last), and a sampler from its first scan.
fn start(model: Model) -> (Ring, Sampler) {
    let mut ring = Converter::start(model, config());
    ring.regs().start_tim3();
    let sampler = Sampler::new(RING, BLOCK, ring.base());
    (ring, sampler)
}

fn model(seed: u64) -> Model {
    ScanModel::new(C, Timing::F405, 0, seed)
}

/// Whether a block holds exactly what the model converted for scans `first..first + BLOCK`, channel by channel.
fn holds_its_scans(first: u64, codes: &[u16; N]) -> bool {
    codes.iter().enumerate().all(|(i, &c)| c == code(first + (i / C) as u64, i % C))
}

/// The consumer: checks every block handed on against the model's codes and every gap against the index.
struct Checker {
    block: [u16; N],
    /// Hardware index the next block would have without a gap.
    next: u64,
    handed: u64,
    /// Blocks handed on holding a code other than the model's for their scan and channel.
    bad: u64,
    /// Blocks whose `skipped` differed from the jump in the index (or that went backwards).
    wrong_gaps: u64,
    /// Scans in the jumps between blocks handed on.
    gap_scans: u64,
    restarts: u64,
    discarded: u64,
    overtaken: u64,
    /// The consumer is behind: no free block.
    behind: bool,
}

impl Checker {
    fn new(first: u64) -> Self {
        Checker {
            block: [0; N],
            next: first,
            handed: 0,
            bad: 0,
            wrong_gaps: 0,
            gap_scans: 0,
            restarts: 0,
            discarded: 0,
            overtaken: 0,
            behind: false,
        }
    }
}

impl BlockSink<N> for Checker {
    fn free_block(&mut self) -> Option<&mut [u16; N]> {
        (!self.behind).then_some(&mut self.block)
    }

    fn hand_on(&mut self, block: &ReadyBlock) {
        if block.first_index < self.next || block.first_index - self.next != block.skipped {
            self.wrong_gaps += 1;
        }
        self.gap_scans += block.first_index.saturating_sub(self.next);
        if !holds_its_scans(block.first_index, &self.block) {
            self.bad += 1;
        }
        self.next = block.first_index + BLOCK as u64;
        self.handed += 1;
    }

    fn note(&mut self, event: SamplerEvent) {
        match event {
            SamplerEvent::Restarted { .. } => self.restarts += 1,
            SamplerEvent::Discarded { .. } => self.discarded += 1,
            SamplerEvent::Overtaken { .. } => self.overtaken += 1,
        }
    }
}

/// A poll of the ring: the sampler's, or the order it replaces.
trait Poll {
    /// A poller from the scan with hardware index `first`, in ring slot 0.
    fn at(first: u64) -> Self;
    fn poll(&mut self, ring: &mut impl ScanRing<N>, sink: &mut Checker);
    fn next_index(&self) -> u64;
    fn lost(&self) -> u64;
}

impl Poll for Sampler {
    fn at(first: u64) -> Self {
        Sampler::new(RING, BLOCK, first)
    }
    fn poll(&mut self, ring: &mut impl ScanRing<N>, sink: &mut Checker) {
        Sampler::poll(self, ring, sink)
    }
    fn next_index(&self) -> u64 {
        Sampler::next_index(self)
    }
    fn lost(&self) -> u64 {
        Sampler::lost(self)
    }
}

/// The order the sampler used to poll in: check once, then copy, confirm and hand on every ready block, with no
/// check after the copy.
struct CheckBeforeCopy(RingReader);

impl Poll for CheckBeforeCopy {
    fn at(first: u64) -> Self {
        CheckBeforeCopy(RingReader::starting_at(RING, BLOCK, first))
    }
    fn poll(&mut self, ring: &mut impl ScanRing<N>, sink: &mut Checker) {
        if let Some(first) = ring.check() {
            self.0.restart_at(first);
            sink.note(SamplerEvent::Restarted { first });
        }
        while let Some(ready) = self.0.poll(ring.started()) {
            let Some(codes) = sink.free_block() else { break };
            ring.copy_block(&ready, codes);
            if !self.0.confirm(ring.started()) {
                sink.note(SamplerEvent::Overtaken { first_index: ready.first_index });
                continue;
            }
            sink.hand_on(&ready);
        }
    }
    fn next_index(&self) -> u64 {
        self.0.next_index()
    }
    fn lost(&self) -> u64 {
        self.0.lost()
    }
}

/// Every scan up to the poller's position is handed on or counted lost, and the count is the gaps' sum.
fn assert_accounted(p: &impl Poll, c: &Checker, first: u64, started: u64) {
    assert_eq!(c.wrong_gaps, 0, "every gap is the jump in the index");
    assert_eq!(p.lost(), c.gap_scans + (p.next_index() - c.next), "lost = the gaps between blocks handed on");
    assert_eq!(c.handed * BLOCK as u64 + p.lost(), p.next_index() - first, "handed on + lost = every scan taken");
    assert!(p.next_index() <= started, "nothing is handed on before it was started");
}

/// Poll every 16 ms for `polls` polls.
fn run(ring: &mut Ring, p: &mut impl Poll, c: &mut Checker, polls: usize) {
    for _ in 0..polls {
        ring.regs().cpu_away(POLL_TICKS);
        p.poll(ring, c);
    }
}

#[test]
fn a_healthy_converter_hands_on_every_scan_in_order() {
    let (mut ring, mut s) = start(model(1));
    let mut c = Checker::new(ring.base());
    run(&mut ring, &mut s, &mut c, 400);
    assert_accounted(&s, &c, 0, ring.regs().scans_started());
    assert_eq!((c.bad, s.lost(), c.restarts + c.discarded + c.overtaken), (0, 0, 0));
    assert!(c.handed >= 400 * 32 / BLOCK as u64 - 2);
    let log = ring.regs().log;
    assert_eq!((log.violations, log.failures, log.total_faults()), (0, 0, 0), "{}", log.last_violation);
    assert!(ring.regs().scans_started() > 3 * RING as u64, "the ring lapped");
}

/// Run a healthy converter a lap and a half (the ring holds an older lap's codes), inject `fault`, poll on, and
/// return the converter, sampler and consumer.
fn one_fault(fault: Fault) -> (Ring, Sampler, Checker) {
    let (mut ring, mut s) = start(model(2));
    let mut c = Checker::new(ring.base());
    run(&mut ring, &mut s, &mut c, 100);
    ring.regs().inject(fault);
    run(&mut ring, &mut s, &mut c, 100);
    assert_accounted(&s, &c, 0, ring.regs().scans_started());
    let log = ring.regs().log;
    assert_eq!(log.faults[fault.index()], 1);
    assert_eq!((log.violations, log.failures), (0, 1), "{}", log.last_violation);
    assert_eq!(c.bad, 0, "no block handed on holds a code other than its own");
    assert!(s.lost() > 0 && s.lost() < 3 * BLOCK as u64, "the fault cost a gap of a few blocks: {}", s.lost());
    assert!(c.handed > 45, "sampling went on after the recovery: {} blocks", c.handed);
    (ring, s, c)
}

#[test]
fn an_overrun_is_recovered_and_costs_an_exact_gap() {
    let (mut ring, ..) = one_fault(Fault::Overrun);
    let log = ring.regs().log;
    assert_eq!((log.failed_overrun, log.failed_position), (1, 0));
}

#[test]
fn a_transfer_error_is_recovered_and_costs_an_exact_gap() {
    let (mut ring, ..) = one_fault(Fault::TransferError);
    let log = ring.regs().log;
    assert_eq!((log.failed_transfer_error, log.failed_stream_off), (1, 1));
}

#[test]
fn a_direct_mode_error_is_recovered_and_costs_an_exact_gap() {
    let (mut ring, ..) = one_fault(Fault::DirectModeError);
    assert_eq!(ring.regs().log.failed_direct_mode_error, 1);
}

#[test]
fn a_stream_that_stops_without_a_flag_is_recovered_and_costs_an_exact_gap() {
    let (mut ring, ..) = one_fault(Fault::StreamStop);
    let log = ring.regs().log;
    assert_eq!((log.failed_stream_off, log.failed_transfer_error), (1, 0));
}

#[test]
fn a_dropped_request_is_found_by_the_position_alone_and_costs_an_exact_gap() {
    let (mut ring, ..) = one_fault(Fault::DroppedRequest);
    let log = ring.regs().log;
    assert_eq!((log.failed_position, log.failed_overrun, log.failed_stream_off), (1, 0, 0));
}

/// One code missing leaves the DMA a single code behind the trigger count: within a scan's codes, which a check
/// that allowed the last scan to be still converting would take for healthy. The check waits for the scan to
/// settle and finds it.
#[test]
fn one_missing_code_is_within_a_scan_of_the_count_and_the_check_still_finds_it() {
    let (mut ring, mut s) = start(model(3));
    let mut c = Checker::new(ring.base());
    run(&mut ring, &mut s, &mut c, 10);
    let m = ring.regs();
    m.inject(Fault::DroppedRequest);
    let next = m.scans_started();
    m.run_until_started(next + 1);
    m.cpu_away(PERIOD / 2);
    let started_codes = (m.scans_started() * C as u64 % CODES as u64) as usize;
    let behind = (started_codes + CODES - m.dma_position()) % CODES;
    assert_eq!(behind, 1, "one code short of the scans started");
    assert!(behind <= C, "a tolerance of one scan would accept it");
    let f = ring.failure().expect("the converter is found failed");
    assert_eq!(f, Failure { position: true, ..Failure::default() });
}

#[test]
fn a_stall_longer_than_the_ring_costs_an_exact_gap_and_no_restart() {
    let (mut ring, mut s) = start(model(4));
    let mut c = Checker::new(ring.base());
    run(&mut ring, &mut s, &mut c, 10);
    // A 2.5 s stall against a 1.024 s ring.
    ring.regs().cpu_away(5000 * PERIOD);
    run(&mut ring, &mut s, &mut c, 10);
    assert_accounted(&s, &c, 0, ring.regs().scans_started());
    assert_eq!((c.bad, c.restarts, c.discarded, ring.regs().log.failures), (0, 0, 0, 0));
    assert!(s.lost() >= 5000 - RING as u64 && s.lost() < 5000, "the ring's lap: {}", s.lost());
}

#[test]
fn the_trigger_count_wraps_at_32_bits_without_a_jump() {
    let start_count = u32::MAX - 1000;
    let (mut ring, mut s) = start(ScanModel::new(C, Timing::F405, start_count, 5));
    let first = ring.base();
    assert_eq!(first, u64::from(start_count));
    let mut c = Checker::new(first);
    run(&mut ring, &mut s, &mut c, 200);
    ring.regs().inject(Fault::Overrun);
    run(&mut ring, &mut s, &mut c, 100);
    assert!(s.next_index() > 1 << 32, "past the wrap");
    assert_accounted(&s, &c, first, ring.regs().scans_started());
    assert_eq!(c.bad, 0);
    assert_eq!(s.lost(), c.gap_scans + (s.next_index() - c.next));
    assert_eq!(ring.regs().log.failures, 1);
}

/// Where the sampler's poll lets the test act on the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Moment {
    /// Just after a check: between it and the copy that follows.
    AfterCheck,
    /// Just before a copy starts reading the ring.
    BeforeCopy,
}

/// The converter with `act` run at each [`Moment`] of the poll: an interrupt, a fault during it.
struct Interfered<'a, F: FnMut(&mut Model, Moment)> {
    ring: &'a mut Ring,
    act: F,
}

impl<F: FnMut(&mut Model, Moment)> ScanRing<N> for Interfered<'_, F> {
    fn started(&mut self) -> u64 {
        self.ring.started()
    }
    fn copy_block(&mut self, block: &ReadyBlock, out: &mut [u16; N]) {
        (self.act)(self.ring.regs(), Moment::BeforeCopy);
        ScanRing::<N>::copy_block(self.ring, block, out)
    }
    fn check(&mut self) -> Option<u64> {
        let r = self.ring.check_and_recover();
        (self.act)(self.ring.regs(), Moment::AfterCheck);
        r
    }
}

/// The window: a lap and a half of healthy polls (the ring holds the lap before), then a poll whose check passes
/// while block B's last scan has not started, and an interrupt just after the check during which the ADC
/// overruns at that scan and two more triggers come. B is then complete by the count, but its last scan was
/// never written: its slots hold the codes of a lap before.
fn poll_through_the_window<P: Poll>() -> (Ring, P, Checker) {
    let (mut ring, _) = start(model(6));
    let mut p = P::at(ring.base());
    let mut c = Checker::new(ring.base());
    run(&mut ring, &mut p, &mut c, 100);
    assert_eq!(c.bad, 0);
    let m = ring.regs();
    let (next, started) = (p.next_index(), m.scans_started());
    // The first block whose last scan (b + BLOCK - 1) comes after the next trigger.
    let b = next + (started + 2 - next).saturating_sub(BLOCK as u64 - 1).div_ceil(BLOCK as u64) * BLOCK as u64;
    m.run_until_started(b + BLOCK as u64 - 2);
    assert_eq!(m.scans_started(), b + BLOCK as u64 - 1, "B's last scan is the next to start");
    let mut once = true;
    let mut r = Interfered {
        ring: &mut ring,
        act: |m: &mut Model, at| {
            if at == Moment::AfterCheck && core::mem::take(&mut once) {
                m.inject(Fault::Overrun);
                m.cpu_away(3 * PERIOD);
            }
        },
    };
    p.poll(&mut r, &mut c);
    assert!(ring.regs().scans_started() > b + BLOCK as u64, "B is complete by the count");
    assert_eq!(ring.regs().log.window_faults, 1, "the fault landed between the check and the copy");
    (ring, p, c)
}

#[test]
fn checking_only_before_the_copy_hands_on_a_lap_old_block_when_a_fault_lands_after_the_check() {
    let (mut ring, p, c) = poll_through_the_window::<CheckBeforeCopy>();
    assert_eq!(c.bad, 1, "the block with the never-written scan was handed on");
    assert_eq!(p.lost(), 0, "and nothing was counted lost");
    assert_eq!(ring.regs().log.failures, 0, "the failure is found only at the next poll");
}

#[test]
fn checking_after_the_copy_throws_that_block_away_and_counts_it_exactly() {
    let (mut ring, mut p, mut c) = poll_through_the_window::<Sampler>();
    assert_eq!((c.bad, c.discarded), (0, 1), "the copy is thrown away");
    assert_eq!(ring.regs().log.failed_overrun, 1);
    run(&mut ring, &mut p, &mut c, 20);
    assert_eq!(c.bad, 0);
    assert!(p.lost() > 0);
    assert_accounted(&p, &c, 0, ring.regs().scans_started());
}

/// The model's rules bite: a recovery that clears OVR and re-arms the DMA but leaves the ADC on resumes the
/// sequencer where the overrun stopped it, and the channels land rotated in the ring.
#[test]
fn a_recovery_that_leaves_the_adc_on_rotates_the_channels() {
    let (mut ring, mut s) = start(model(7));
    let mut c = Checker::new(ring.base());
    run(&mut ring, &mut s, &mut c, 10);
    let m = ring.regs();
    // Let the overrun hit the second code of a scan.
    let next = m.scans_started();
    m.run_until_started(next);
    m.inject(Fault::DroppedRequest);
    m.inject(Fault::Overrun);
    m.cpu_away(PERIOD);
    let sr = m.adc_sr();
    assert_ne!(sr & adc_sr::OVR, 0);
    m.set_adc_sr(sr & !adc_sr::OVR);
    arm_dma(m, CODES);
    let cr2 = m.adc_cr2();
    m.set_adc_cr2(cr2 & !adc_cr2::DMA);
    m.set_adc_cr2(cr2 | adc_cr2::DMA);
    let first = m.scans_started();
    m.run_until_started(first + 1);
    m.cpu_away(PERIOD / 2);
    let mut out = [0u16; C];
    m.read_ring(0, &mut out);
    assert_eq!(out[0], code(first, 2), "the sequencer went on from the third channel");
    assert_ne!(out[0], code(first, 0));
    assert_eq!(m.log.violations, 0, "{}", m.log.last_violation);
}

/// The model's rules bite: the stream is not reconfigured while it runs, and not enabled before its flags
/// (TCIF, set when software disabled it) are cleared; the ADC's DMA requests are not re-enabled with OVR set.
#[test]
fn the_model_holds_the_driver_to_the_streams_and_the_adcs_rules() {
    let mut m = model(8);
    m.set_dma_ndtr(CODES as u32);
    m.set_dma_cr(dma_cr::RING | dma_cr::EN);
    assert!(m.stream_enabled());
    assert_eq!(m.log.violations, 0);
    m.set_dma_ndtr(1);
    assert_eq!(m.log.violations, 1, "NDTR written while the stream runs");
    m.set_dma_cr(dma_cr::RING);
    assert_ne!(m.dma_cr() & dma_cr::EN, 0, "EN reads 1 until the current transfer ends");
    assert_eq!(m.dma_cr() & dma_cr::EN, 0);
    assert_ne!(m.dma_flags() & dma_flags::TCIF, 0, "disabling the stream sets TCIF");
    m.set_dma_cr(dma_cr::RING | dma_cr::EN);
    assert!(!m.stream_enabled(), "not enabled with a flag set");
    assert_eq!(m.log.violations, 2);
    m.clear_dma_flags(dma_flags::ALL);
    m.set_dma_cr((dma_cr::RING & !dma_cr::CIRC) | dma_cr::EN);
    assert!(!m.stream_enabled(), "not enabled other than as the ring");
    assert_eq!(m.log.violations, 3);
    m.set_dma_cr(dma_cr::RING | dma_cr::EN);
    assert!(m.stream_enabled());

    m.inject(Fault::Overrun);
    m.set_adc_cr2(adc_cr2::DDS | adc_cr2::EXTSEL_TIM3_TRGO | adc_cr2::DMA | adc_cr2::ADON | adc_cr2::EXTEN_RISING);
    m.start_tim3();
    m.run_until_started(0);
    m.cpu_away(PERIOD / 2);
    assert_ne!(m.adc_sr() & adc_sr::OVR, 0);
    let cr2 = m.adc_cr2();
    m.set_adc_cr2(cr2 & !adc_cr2::DMA);
    m.set_adc_cr2(cr2);
    assert_eq!((m.log.violations, m.log.last_violation), (4, "ADC_CR2.DMA set again with OVR still set"));
}

#[test]
fn a_copy_the_dma_overtakes_is_thrown_away_and_counted() {
    let (mut ring, mut s) = start(model(9));
    let mut c = Checker::new(ring.base());
    run(&mut ring, &mut s, &mut c, 10);
    // A stall leaves the reader at the ring's oldest complete block; the CPU is taken away again just before
    // the copy, long enough for the DMA to reach it.
    ring.regs().cpu_away(3000 * PERIOD);
    let mut once = true;
    let mut r = Interfered {
        ring: &mut ring,
        act: |m: &mut Model, at| {
            if at == Moment::BeforeCopy && core::mem::take(&mut once) {
                m.cpu_away(2 * BLOCK as u64 * PERIOD);
            }
        },
    };
    s.poll(&mut r, &mut c);
    assert_eq!((c.overtaken, c.bad, ring.regs().log.failures), (1, 0, 0));
    run(&mut ring, &mut s, &mut c, 10);
    assert_accounted(&s, &c, 0, ring.regs().scans_started());
    assert_eq!(c.bad, 0);
}

/// What one randomised session did.
struct Session {
    first: u64,
    started: u64,
    next_index: u64,
    lost: u64,
    checker: Checker,
    log: super::model::ModelLog,
    long_stalls: u64,
}

/// A session of `polls` polls, with:
/// - faults arriving at random times (a mean gap of 0.128 s to 4 s, a random mix of kinds);
/// - the CPU taken away at random register accesses and code reads (for up to 1 to 256 trigger periods);
/// - after some checks, the CPU away for up to two blocks' time with a fault arriving meanwhile (the window
///   between the check and the copy), and before some copies the CPU away as long (the DMA may overtake them);
/// - stalls shorter and longer than the ring between polls, and a consumer that is sometimes behind;
/// - a trigger count that starts anywhere (a quarter of the sessions wrap it).
fn session<P: Poll>(seed: u64, polls: usize) -> Session {
    let mut rng = SimRng::new(SimRng::derive_seed(0xADC, seed));
    let tim5_start = if seed.is_multiple_of(4) {
        u32::MAX - (rng.next_u64() % (8 * RING as u64)) as u32
    } else {
        rng.next_u64() as u32
    };
    let mut m = ScanModel::new(C, Timing::F405, tim5_start, rng.next_u64());
    let gap = PERIOD << (8 + rng.next_u64() % 6);
    let mut weights = [0u32; 5];
    while weights.iter().all(|&w| w == 0) {
        weights.iter_mut().for_each(|w| *w = (rng.next_u64() % 4) as u32);
    }
    m.random_faults(gap, weights);
    m.interrupts((rng.next_u64() % 65) as u32, (PERIOD << (rng.next_u64() % 9)) as u32);
    let (mut ring, _) = start(m);
    let first = ring.base();
    let mut p = P::at(first);
    let mut c = Checker::new(first);
    let mut long_stalls = 0;
    let mut window_rng = SimRng::new(rng.next_u64());
    let window_chance = rng.next_u64() % 64;
    for _ in 0..polls {
        let away = match rng.next_u64() % 203 {
            0..=197 => POLL_TICKS - PERIOD + rng.next_u64() % (2 * PERIOD),
            198..=201 => rng.next_u64() % (1800 * PERIOD),
            _ => {
                long_stalls += 1;
                (2100 + rng.next_u64() % 4000) * PERIOD
            }
        };
        ring.regs().cpu_away(away);
        c.behind = rng.next_u64().is_multiple_of(10);
        let mut r = Interfered {
            ring: &mut ring,
            act: |m: &mut Model, at| {
                if window_rng.next_u64() % 256 < window_chance {
                    let longest = PERIOD << (window_rng.next_u64() % 9);
                    m.cpu_away(window_rng.next_u64() % longest);
                    if at == Moment::AfterCheck {
                        m.inject(Fault::ALL[(window_rng.next_u64() % 5) as usize]);
                    }
                }
            },
        };
        p.poll(&mut r, &mut c);
    }
    let started = ring.regs().scans_started();
    Session {
        first,
        started,
        next_index: p.next_index(),
        lost: p.lost(),
        log: ring.regs().log,
        long_stalls,
        checker: c,
    }
}

/// Sessions of the randomised tests, and polls in each (4 s of polling).
const SESSIONS: u64 = 384;
const POLLS: usize = 250;

#[test]
fn twenty_thousand_random_faults_hand_on_no_stale_or_rotated_block_and_every_gap_is_exact() {
    let mut faults = [0u64; 5];
    let (mut window, mut handed, mut lost, mut scans, mut failures, mut discarded, mut overtaken, mut long_stalls) =
        (0, 0, 0, 0, 0, 0, 0, 0);
    for seed in 0..SESSIONS {
        let s = session::<Sampler>(seed, POLLS);
        let c = &s.checker;
        assert_eq!(c.bad, 0, "session {seed}: a block handed on held a code not its own");
        assert_eq!(c.wrong_gaps, 0, "session {seed}: a gap differed from the jump in the index");
        assert_eq!(s.lost, c.gap_scans + (s.next_index - c.next), "session {seed}: lost = the gaps");
        assert_eq!(c.handed * BLOCK as u64 + s.lost, s.next_index - s.first, "session {seed}: every scan taken");
        assert!(s.next_index <= s.started);
        assert_eq!(s.log.violations, 0, "session {seed}: {}", s.log.last_violation);
        faults.iter_mut().zip(s.log.faults).for_each(|(t, f)| *t += f);
        window += s.log.window_faults;
        handed += c.handed;
        lost += s.lost;
        scans += s.started - s.first;
        failures += s.log.failures;
        discarded += c.discarded;
        overtaken += c.overtaken;
        long_stalls += s.long_stalls;
    }
    let total: u64 = faults.iter().sum();
    eprintln!(
        "faults {total} {faults:?} ({window} between a check and a copy's end), {failures} failures found, \
         {discarded} copies thrown away after a failure and {overtaken} overtaken by the DMA, {long_stalls} stalls \
         longer than the ring; {handed} blocks handed on, \
         {lost} of {scans} scans lost"
    );
    assert!(total >= 20_000, "{total} faults");
    assert!(faults.iter().all(|&f| f >= 500), "every kind, many times: {faults:?}");
    assert!(window >= 1000 && discarded >= 1000, "faults in the window: {window}, copies thrown away: {discarded}");
    assert!(overtaken > 0 && long_stalls > 0);
    assert!(handed * BLOCK as u64 > scans / 4, "a quarter of the scans or more are handed on and checked");
}

#[test]
fn the_same_faults_make_the_check_before_copy_order_hand_on_bad_blocks() {
    let bad: u64 = (0..SESSIONS).map(|seed| session::<CheckBeforeCopy>(seed, POLLS).checker.bad).sum();
    assert!(bad > 0, "the old order hands on no bad block under the random faults");
    eprintln!("check-before-copy: {bad} bad blocks handed on");
}
