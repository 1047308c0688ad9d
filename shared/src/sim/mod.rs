//! The virtual gyro + ADC (being written).
