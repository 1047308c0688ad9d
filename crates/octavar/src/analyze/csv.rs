//! The CSV `octavar analyze --csv` writes, and the demo's `adev.csv`: one row per deviation point.

use std::fmt::Write as _;

use super::ChannelAnalysis;
use crate::stats::{DevPoint, Statistic};

/// Every point of every statistic as CSV: `channel,stat,m,tau_s,n,alpha,lo,dev,hi,edf`.
pub fn to_csv(channels: &[ChannelAnalysis]) -> String {
    points_csv(channels.iter().flat_map(|c| c.stats.iter().map(|(stat, pts)| (c.name.as_str(), *stat, &pts[..]))))
}

/// The CSV of deviation points: a header, then one row per point of each (channel, statistic, points), as
/// `analyze --csv` and the demo's `adev.csv` write it (`channel,stat,m,tau_s,n,alpha,lo,dev,hi,edf`).
pub fn points_csv<'a>(series: impl IntoIterator<Item = (&'a str, Statistic, &'a [DevPoint])>) -> String {
    let mut s = String::from("channel,stat,m,tau_s,n,alpha,lo,dev,hi,edf\n");
    for (channel, stat, pts) in series {
        for p in pts {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{}",
                channel,
                stat.name().to_ascii_lowercase(),
                p.m,
                p.tau_s,
                p.n,
                p.alpha,
                p.lo,
                p.dev,
                p.hi,
                p.edf
            );
        }
    }
    s
}
