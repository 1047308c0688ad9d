//! The simulation model `octavar analyze --model-out` writes: the fitted terms as a bench `simulate` and `gap`
//! read.

use octavar_shared::sensor::{Channel, SensorKind, GENERIC};
use octavar_shared::sim::{BenchSim, ChannelSim, GyroSim};

use super::ChannelAnalysis;

/// A simulation model from the fits: one generic channel per analysed channel, with the identifiable terms
/// (a term that is not identifiable is left out). The channel's ADC is fine enough (16 bits over +/-range)
/// that it adds no visible quantisation; `gap` adds quantisation as an effect where the data show a lattice.
pub fn model_from_fits(channels: &[ChannelAnalysis], rate_hz: f64, data_range_dps: f64) -> BenchSim {
    let mut out = heapless::Vec::new();
    for c in channels.iter().take(octavar_shared::sim::MAX_CHANNELS) {
        let Ok(f) = &c.fit else { continue };
        let gyro = f.sim_terms(GyroSim::default());
        let _ = out.push(ChannelSim { sensor: SensorKind::Generic, channel: Some(fine_channel(data_range_dps)), gyro });
    }
    BenchSim { rate_hz, seed: 0, temperature: Default::default(), channels: out }
}

/// A generic channel whose 16-bit ADC spans +/-`range_dps`.
pub fn fine_channel(range_dps: f64) -> Channel {
    let range = if range_dps.is_finite() && range_dps > 0.0 { range_dps } else { 100.0 };
    let adc = octavar_shared::sensor::Adc { bits: 16, vref_mv: 3300.0 };
    let gyro = octavar_shared::sensor::GyroModel {
        sensitivity_mv_per_dps: 1650.0 / range,
        null_mv: 1650.0,
        range_dps: range,
        ..GENERIC
    };
    Channel { gyro, front: octavar_shared::sensor::FrontEnd::WIRE, adc }
}
