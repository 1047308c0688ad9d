//! octavar's end-to-end tests, built as one binary (one module per claim area).

mod acc_allantools;
mod corruption;
mod demo_bench;
mod exports;
mod fft_gyro;
mod fit_coverage;
mod gap_evidence;
mod gap_real;
mod gap_sweep;
mod gap_withheld;
mod imu_bags;
mod indep_gyro;
mod interval_coverage;
mod pipeline;
mod qemu;
mod reference_adis;
mod reference_nbs14;
mod reference_stable32;
mod ros2_bag;
mod sim_closed_form;
mod sim_narrowband;
mod tdms;
mod transients;
mod util;
