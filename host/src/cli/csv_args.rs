//! The recording flags `analyze` and `gap` share: the sample rate or a time column, the unit, skipped rows and
//! row filters, the CSV dialect, a bag's topic, and the read options they make.

use octavar::io::csv::rows::Delimiter;
use octavar::io::csv::{CsvOptions, RowFilter};
use octavar::io::formats::ReadOptions;
use octavar::io::recording::{AccelUnit, RateUnit};

/// How to read a rate recording.
#[derive(Debug, clap::Args)]
pub struct CsvArgs {
    /// Sample rate in Hz (or give --time-column).
    #[arg(long, value_name = "HZ")]
    pub rate: Option<f64>,
    /// A time column in seconds: the rate is its median step; missing samples become gaps.
    #[arg(long, value_name = "NAME")]
    pub time_column: Option<String>,
    /// Unit of the rate columns: deg/s, rad/s, mrad/s, deg/h.
    #[arg(long, default_value = "deg/s")]
    pub unit: String,
    /// Unit of the accelerometer columns: m/s^2, g, mg.
    #[arg(long, default_value = "m/s^2", value_name = "UNIT")]
    pub accel_unit: String,
    /// Lines to skip before the header.
    #[arg(long, default_value_t = 0)]
    pub skip_rows: usize,
    /// Keep only rows where COLUMN equals VALUE (repeatable), e.g. --where period=1.
    #[arg(long = "where", value_name = "COLUMN=VALUE")]
    pub filters: Vec<String>,
    /// The cell delimiter: `,` `;` `tab` `whitespace` `|` (default: detected from the header line).
    #[arg(long, value_name = "DELIM")]
    pub delimiter: Option<String>,
    /// Numbers are written with a decimal comma (`1,25`); detected where the delimiter is not a comma.
    #[arg(long)]
    pub decimal_comma: bool,
    /// Accept rows with more or fewer fields than the header (otherwise such a row is an error).
    #[arg(long)]
    pub flexible: bool,
    /// The IMU topic of a ROS bag (.mcap, .db3 or a rosbag2 folder, ROS 1 .bag), e.g. /imu/data (default: the
    /// bag's only sensor_msgs Imu topic).
    #[arg(long, value_name = "TOPIC")]
    pub topic: Option<String>,
}

impl CsvArgs {
    /// The unit of `--unit`.
    pub fn rate_unit(&self) -> anyhow::Result<RateUnit> {
        Ok(RateUnit::parse(&self.unit)?)
    }

    /// The CSV options for the rate `columns` and the accelerometer columns `accel` (and a temperature column),
    /// with `filters` as the row filters (the `--where` flags, or another set such as gap's `--holdout-where`).
    pub fn options(
        &self,
        (columns, accel): (Vec<String>, Vec<String>),
        temp_column: Option<String>,
        filters: &[String],
    ) -> anyhow::Result<CsvOptions> {
        Ok(CsvOptions {
            columns,
            accel_columns: accel,
            accel_unit: AccelUnit::parse(&self.accel_unit)?,
            temp_column,
            rate_hz: self.rate,
            time_column: self.time_column.clone(),
            unit: self.rate_unit()?,
            skip_rows: self.skip_rows,
            filters: filters.iter().map(|f| RowFilter::parse(f)).collect::<Result<Vec<_>, _>>()?,
            delimiter: self.delimiter.as_deref().map(Delimiter::parse).transpose().map_err(anyhow::Error::msg)?,
            decimal_comma: self.decimal_comma.then_some(true),
            flexible: self.flexible,
        })
    }

    /// The options of any format: the CSV options as [`CsvArgs::options`] makes them, the bag's topic and a raw
    /// input's channel count.
    pub fn read_options(
        &self,
        columns: (Vec<String>, Vec<String>),
        temp_column: Option<String>,
        filters: &[String],
        channels: usize,
    ) -> anyhow::Result<ReadOptions> {
        Ok(ReadOptions { csv: self.options(columns, temp_column, filters)?, topic: self.topic.clone(), channels })
    }
}
