//! Throughput of the virtual gyro (`octavar_shared::sim`): samples per second on one core.
//!
//! The floor is 50 million samples/s for N + B + K with the ADC. Criterion reports time per block of
//! `BLOCK` samples and the throughput in elements (samples) per second.
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use octavar_shared::sensor::{Channel, ADXRS300};
use octavar_shared::sim::{
    BenchSim, BiasSteps, ChannelSim, GaussMarkovSim, GyroSim, Outliers, Sinusoid, TempCoupling, TemperatureProfile,
    VirtualGyro, Wander,
};

const BLOCK: u64 = 1 << 16;

fn nbk() -> GyroSim {
    GyroSim { bias_dps: 0.2, n_deg_per_rt_s: 0.046, b_dps: 0.026, k_dps_per_rt_s: 1e-4, ..Default::default() }
}

fn full() -> GyroSim {
    let mut sinusoids = heapless::Vec::new();
    sinusoids.push(Sinusoid { amplitude_dps: 0.05, period_s: 0.02, phase_rad: 0.0 }).unwrap();
    sinusoids.push(Sinusoid { amplitude_dps: 0.01, period_s: 0.3, phase_rad: 1.0 }).unwrap();
    GyroSim {
        r_dps_per_s: 1e-6,
        gauss_markov: Some(GaussMarkovSim { sigma_dps: 0.01, tau_s: 5.0 }),
        bandwidth_hz: Some(40.0),
        sinusoids,
        temperature: Some(TempCoupling { dps_per_c: 0.01, ref_c: 25.0, lag_s: 600.0 }),
        bias_steps: Some(BiasSteps { per_hour: 2.0, sigma_dps: 0.01 }),
        outliers: Some(Outliers { per_sample: 1e-5, size_sigma: 8.0, ..Default::default() }),
        ..nbk()
    }
}

fn run(g: &mut VirtualGyro) -> u64 {
    let mut acc = 0u64;
    for _ in 0..BLOCK {
        acc += u64::from(g.next(black_box(25.0)).code);
    }
    acc
}

fn sim(c: &mut Criterion) {
    let ch = Channel::bench(ADXRS300);
    let mut group = c.benchmark_group("sim");
    group.throughput(Throughput::Elements(BLOCK));
    for (name, model) in [
        ("white_only+adc", GyroSim { n_deg_per_rt_s: 0.046, ..Default::default() }),
        ("n_b_k+adc", nbk()),
        ("full+adc", full()),
    ] {
        let mut g = VirtualGyro::new(&model, ch, 2000.0, 1).unwrap();
        group.bench_function(name, |b| b.iter(|| run(&mut g)));
    }
    let mut g = VirtualGyro::new(&nbk(), ch, 2000.0, 1).unwrap();
    group.bench_function("n_b_k_rate_only", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for _ in 0..BLOCK {
                s += g.next_rate(25.0);
            }
            s
        })
    });
    let mut channels = heapless::Vec::new();
    for _ in 0..5 {
        channels.push(ChannelSim { sensor: ADXRS300.kind, channel: None, gyro: full() }).unwrap();
    }
    let model = BenchSim {
        rate_hz: 2000.0,
        seed: 1,
        temperature: TemperatureProfile {
            min_c: 22.0,
            max_c: 25.0,
            wander: Some(Wander { sigma_c: 0.1, tau_s: 1800.0 }),
            ..Default::default()
        },
        channels,
    };
    let mut bench = octavar_shared::sim::Bench::new(&model).unwrap();
    group.throughput(Throughput::Elements(5 * BLOCK));
    group.bench_function("bench_5ch_full", |b| {
        b.iter(|| {
            let mut acc = 0u64;
            for _ in 0..BLOCK {
                acc += u64::from(bench.next_sample().codes[4]);
            }
            acc
        })
    });
    group.finish();
}

criterion_group!(benches, sim);
criterion_main!(benches);
