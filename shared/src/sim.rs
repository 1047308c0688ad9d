//! The virtual gyro + ADC (work in progress).
