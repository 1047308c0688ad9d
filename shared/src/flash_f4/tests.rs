//! The controller sequences against the model of RM0090's rules.

use super::model::ControllerModel;
use super::*;
use crate::fieldlog::{FieldLog, STM32F405_LOG_SECTORS};

/// The board's two log sectors, 16 KiB each, all backed.
type Board = ControllerModel<4096>;

fn board() -> Board {
    ControllerModel::new(STM32F405_LOG_SECTORS)
}

const SECTOR1: u32 = 0x0800_4000;

#[test]
fn an_erase_runs_at_x32_within_half_a_second_and_leaves_the_controller_locked() {
    let mut m = board();
    program(&mut m, SECTOR1 + 8, &[0x1234_5678, 0]).unwrap();
    erase_sector(&mut m, 1, SECTOR1).unwrap();
    assert_eq!(m.log.violations, 0);
    assert_eq!(m.log.erases, 1);
    assert_eq!(m.log.parallelism, Some(Parallelism::X32));
    assert_eq!(m.log.longest_us, 500_000, "a 16 KiB sector's worst case at x32");
    assert_ne!(m.cr() & cr::LOCK, 0, "locked again");
    assert!((0..4096).all(|i| m.load(SECTOR1 + 4 * i) == u32::MAX), "the whole sector erased");
}

/// embassy-stm32 0.6's F4 erase modifies FLASH_CR without setting PSIZE, after a program sequence that wrote
/// CR whole (PSIZE 0, x8): the model charges it the x8 worst case, 0.8 s, which the firmware's ring could not
/// cover 1.5 times.
#[test]
fn an_erase_that_leaves_psize_at_x8_takes_the_x8_worst_case() {
    let mut m = board();
    m.key(KEYS[0]);
    m.key(KEYS[1]);
    m.set_cr(cr::PG | (Parallelism::X32.bits() << cr::PSIZE_SHIFT));
    m.set_cr(0); // disable_blocking_write: cr().write(|w| w.set_pg(false))
    let select = m.cr() | cr::SER | (1 << cr::SNB_SHIFT);
    m.set_cr(select);
    m.set_cr(select | cr::STRT);
    while m.sr() & sr::BSY != 0 {}
    assert_eq!(m.log.parallelism, Some(Parallelism::X8));
    assert_eq!(m.log.longest_us, 800_000);
    assert!(erase_worst_us(16 * 1024, Parallelism::X8) * 2 > 3 * erase_worst_us(16 * 1024, PARALLELISM));
}

#[test]
fn programming_writes_each_word_at_x32_and_charges_each_its_worst_case() {
    let mut m = board();
    let words: [u32; 5] = [1, 2, 0xFFFF_0000, 0, 0xDEAD_BEEF];
    program(&mut m, SECTOR1 + 64, &words).unwrap();
    assert_eq!(m.log.violations, 0);
    assert_eq!((m.log.words, m.log.longest_us), (5, 5 * PROGRAM_OP_WORST_US));
    assert_eq!(m.log.longest_us, program_worst_us(5, PARALLELISM));
    for (i, w) in words.iter().enumerate() {
        assert_eq!(m.load(SECTOR1 + 64 + 4 * i as u32), *w);
    }
    assert_ne!(m.cr() & cr::LOCK, 0);
    // NOR flash: programming clears bits only.
    program(&mut m, SECTOR1 + 64, &[0xF0F0_F0F0]).unwrap();
    assert_eq!(m.load(SECTOR1 + 64), 1 & 0xF0F0_F0F0);
}

#[test]
fn a_failed_program_names_the_word_and_its_flags_and_the_next_operation_starts_clean() {
    let mut m = board();
    m.inject(FlashOp::Program, sr::WRPERR);
    let e = program(&mut m, SECTOR1, &[7, 8, 9]).unwrap_err();
    assert_eq!(e, FlashError { op: FlashOp::Program, flags: sr::WRPERR, address: SECTOR1 });
    assert_eq!(m.load(SECTOR1 + 4), u32::MAX, "nothing after the failing word is programmed");
    assert_ne!(m.cr() & cr::LOCK, 0, "locked after a failure too");
    program(&mut m, SECTOR1, &[7, 8, 9]).unwrap();
    assert_eq!(m.load(SECTOR1 + 8), 9);
    let text = format!("{e}");
    assert!(text.contains("WRPERR") && text.contains("0x08004000"), "{text}");
    assert_eq!(m.log.violations, 0);
}

#[test]
fn a_failed_erase_is_an_error_with_its_flags() {
    let mut m = board();
    m.inject(FlashOp::Erase, sr::OPERR | sr::WRPERR);
    let e = erase_sector(&mut m, 2, 0x0800_8000).unwrap_err();
    assert_eq!((e.op, e.flags), (FlashOp::Erase, sr::OPERR | sr::WRPERR));
    assert_eq!(m.sr() & sr::ERRORS, 0, "the flags were cleared");
    erase_sector(&mut m, 2, 0x0800_8000).unwrap();
}

#[test]
fn the_field_log_runs_on_the_controller_with_no_rule_broken_and_no_stall_over_half_a_second() {
    // The QEMU build's geometry: 8 KiB of each sector backed, two 792-word checkpoints per sector.
    let flash = F4LogFlash::new(ControllerModel::<2048>::new(STM32F405_LOG_SECTORS), STM32F405_LOG_SECTORS, 2048);
    let mut log = FieldLog::open(flash, 787).unwrap();
    let mut payload = [0u32; 787];
    for k in 1..=9u32 {
        payload.iter_mut().enumerate().for_each(|(i, w)| *w = k * 1000 + i as u32);
        log.prepare_append().unwrap();
        assert_eq!(log.append(&payload).unwrap(), k);
    }
    let mut flash = log.into_flash();
    let m = flash.regs();
    assert_eq!(m.log.violations, 0);
    assert_eq!(m.log.erases, 5, "one at the start and one every two records");
    assert_eq!(m.log.words, 9 * 792);
    assert_eq!(m.log.longest_us, erase_worst_us(16 * 1024, Parallelism::X32));
    m.reset();
    let mut log = FieldLog::open(flash, 787).unwrap();
    assert_eq!(log.read_latest(&mut payload).unwrap(), Some(9));
    assert_eq!(payload[786], 9786);
}

#[test]
fn prepare_append_takes_the_erase_out_of_the_append() {
    let flash = F4LogFlash::new(ControllerModel::<2048>::new(STM32F405_LOG_SECTORS), STM32F405_LOG_SECTORS, 2048);
    let mut log = FieldLog::open(flash, 787).unwrap();
    let payload = [5u32; 787];
    let mut erased = [false; 6];
    for e in &mut erased {
        let before = log.flash_mut().regs().log.erases;
        *e = log.prepare_append().unwrap();
        let prepared = log.flash_mut().regs().log.erases;
        assert_eq!(prepared, before + u32::from(*e), "prepare_append says whether it erased");
        log.append(&payload).unwrap();
        assert_eq!(log.flash_mut().regs().log.erases, prepared, "an append after a prepare never erases");
    }
    // Two records per sector: the empty log's first sector, then the other one every second record.
    assert_eq!(erased, [true, false, true, false, true, false]);
}

#[test]
fn a_wrong_key_keeps_the_controller_locked_and_the_operation_fails() {
    let mut m = board();
    m.key(0x1111_1111);
    let e = erase_sector(&mut m, 1, SECTOR1).unwrap_err();
    assert_eq!((e.op, e.flags), (FlashOp::Unlock, 0));
    assert_eq!(m.log.erases, 0);
    m.reset();
    erase_sector(&mut m, 1, SECTOR1).unwrap();
}

#[test]
fn the_brown_out_level_is_written_once_checked_and_locked() {
    let mut m = board();
    assert_eq!(brown_out_level(&mut m), BrownOut::Off, "factory option bytes");
    assert_eq!(set_brown_out_level(&mut m, BrownOut::Level3), Ok(OptionWrite::Written));
    assert_eq!(m.log.violations, 0);
    assert_ne!(m.optcr() & optcr::OPTLOCK, 0, "locked again");
    assert_eq!((m.option_bytes() & optcr::BOR_MASK) >> optcr::BOR_SHIFT, 0);
    assert_eq!(m.option_bytes() & !optcr::BOR_MASK, optcr::RESET & !optcr::BOR_MASK & !optcr::OPTLOCK);
    m.reset();
    assert_eq!(brown_out_level(&mut m), BrownOut::Level3);
    assert_eq!(set_brown_out_level(&mut m, BrownOut::Level3), Ok(OptionWrite::AlreadySet));
    assert_eq!(m.log.option_writes, 1, "not written again");
}

#[test]
fn a_failed_brown_out_write_is_reported_as_a_failure_and_changes_nothing() {
    let mut m = board();
    m.inject(FlashOp::OptionBytes, sr::OPERR);
    let e = set_brown_out_level(&mut m, BrownOut::Level3).unwrap_err();
    assert_eq!((e.op, e.flags), (FlashOp::OptionBytes, sr::OPERR));
    assert_ne!(m.optcr() & optcr::OPTLOCK, 0, "locked again");
    m.reset();
    assert_eq!(brown_out_level(&mut m), BrownOut::Off, "the option bytes kept their old level");
    assert_eq!(m.log.option_writes, 0);
}
