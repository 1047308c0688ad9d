//! A bag's topics as every container reader gathers them: which are Imu topics, how many messages each has, the
//! decoded messages of the wanted ones as [`Sample`]s, and the choice of the topic to read (the only Imu topic, or
//! the one named) with the errors that list the choices.

use super::BagError;

/// Which messages a scan decodes.
pub(crate) enum Want {
    /// None: count them.
    Nothing,
    /// Those of every Imu topic.
    AllImu,
    /// Those of one topic.
    Topic(String),
}

/// One decoded Imu message, whatever its serialization: the fields octavar keeps.
pub(crate) struct Message<'a> {
    /// `header.stamp`, ns.
    pub(crate) stamp_ns: i64,
    /// When the recorder logged the message, ns.
    pub(crate) log_time: u64,
    pub(crate) frame_id: &'a str,
    /// `angular_velocity`, rad/s.
    pub(crate) w: [f64; 3],
    /// `linear_acceleration`, m/s^2.
    pub(crate) a: [f64; 3],
    /// `linear_acceleration_covariance[0]`: REP 145 marks an acceleration the message does not give with -1.
    pub(crate) a_cov0: f64,
}

/// One message kept: its times, angular velocity (rad/s) and linear acceleration (m/s^2).
#[derive(Clone, Copy)]
pub(crate) struct Sample {
    pub(crate) stamp_ns: i64,
    pub(crate) log_time: u64,
    pub(crate) w: [f64; 3],
    pub(crate) a: [f64; 3],
    /// Whether the message gives its acceleration.
    pub(crate) a_given: bool,
}

/// One topic of the bag.
#[derive(Default)]
pub(crate) struct Topic {
    pub(crate) name: String,
    /// Whether some connection of it is an Imu connection octavar reads.
    pub(crate) imu: bool,
    /// What a connection of it that is not such carries (for errors).
    pub(crate) other: Option<String>,
    pub(crate) messages: u64,
    pub(crate) samples: Vec<Sample>,
    pub(crate) frame_id: Option<String>,
    /// The first message that failed to decode.
    pub(crate) error: Option<BagError>,
}

impl Topic {
    /// Count one message of this topic, sent on a connection that is (`imu`) an Imu connection or not; whether
    /// `want` asks for it decoded (and no earlier message failed).
    pub(crate) fn count(&mut self, want: &Want, imu: bool) -> bool {
        self.messages += 1;
        let wanted = match want {
            Want::Nothing => false,
            Want::AllImu => imu,
            Want::Topic(name) => imu && *name == self.name,
        };
        wanted && self.error.is_none()
    }

    /// Take the message just counted, or its decoding error; `kind` is the message type and `at` the place of
    /// the message in the file (empty, or e.g. ` (row id 17)`), both for the error.
    pub(crate) fn take(
        &mut self,
        path: &str,
        kind: &'static str,
        at: impl FnOnce() -> String,
        decoded: Result<Message<'_>, String>,
    ) {
        let index = self.messages;
        let m = match decoded {
            Ok(m) => m,
            Err(what) => {
                let (path, topic, at) = (path.to_string(), self.name.clone(), at());
                self.error = Some(BagError::Decode { path, topic, index, at, kind, what });
                return;
            }
        };
        let a_given = m.a_cov0 != -1.0;
        let infinite = (0..3)
            .find(|&i| m.w[i].is_infinite())
            .map(|i| (["x", "y", "z"][i], m.w[i]))
            .or_else(|| (0..3).find(|&i| a_given && m.a[i].is_infinite()).map(|i| (["ax", "ay", "az"][i], m.a[i])));
        if let Some((axis, value)) = infinite {
            let (path, topic) = (path.to_string(), self.name.clone());
            self.error = Some(BagError::NotFinite { path, topic, index, axis, value });
            return;
        }
        if self.frame_id.is_none() {
            self.frame_id = Some(m.frame_id.to_string());
        }
        self.samples.push(Sample { stamp_ns: m.stamp_ns, log_time: m.log_time, w: m.w, a: m.a, a_given });
    }
}

/// The topics of one bag, as a scan of it found them.
pub(crate) struct Topics {
    /// The file, for errors.
    pub(crate) path: String,
    /// The Imu message type of this kind of bag (`sensor_msgs/msg/Imu`, `sensor_msgs/Imu`).
    pub(crate) kind: &'static str,
    pub(crate) list: Vec<Topic>,
}

impl Topics {
    /// No topics yet.
    pub(crate) fn new(path: String, kind: &'static str) -> Topics {
        Topics { path, kind, list: Vec::new() }
    }

    /// The index of the topic `name`, added if new.
    pub(crate) fn index(&mut self, name: &str) -> usize {
        match self.list.iter().position(|t| t.name == name) {
            Some(i) => i,
            None => {
                self.list.push(Topic { name: name.to_string(), ..Topic::default() });
                self.list.len() - 1
            }
        }
    }

    /// Note that topic `i` has a connection that is (`imu`) an Imu connection, or else carries `other()`.
    pub(crate) fn connection(&mut self, i: usize, imu: bool, other: impl FnOnce() -> String) {
        let t = &mut self.list[i];
        if imu {
            t.imu = true;
        } else if t.other.is_none() {
            t.other = Some(other());
        }
    }

    /// The Imu topics with their message counts, by name.
    pub(crate) fn imu_topics(&self) -> Vec<(String, u64)> {
        let mut topics: Vec<(String, u64)> =
            self.list.iter().filter(|t| t.imu).map(|t| (t.name.clone(), t.messages)).collect();
        topics.sort();
        topics
    }

    /// `name (N messages), ...` for the topics `keep` selects, by name, or `none`.
    fn listing(&self, keep: impl Fn(&Topic) -> bool, with_type: bool) -> String {
        let mut items: Vec<String> = self
            .list
            .iter()
            .filter(|t| keep(t))
            .map(|t| {
                let kind = match (&t.other, t.imu) {
                    (_, true) => self.kind.to_string(),
                    (Some(o), false) => o.clone(),
                    (None, false) => "?".to_string(),
                };
                if with_type {
                    format!("{} ({kind}, {} messages)", t.name, t.messages)
                } else {
                    format!("{} ({} messages)", t.name, t.messages)
                }
            })
            .collect();
        items.sort();
        if items.is_empty() {
            "none".to_string()
        } else {
            items.join(", ")
        }
    }

    /// Take out the topic to read: `topic`, or without one the only Imu topic; or the error that lists the
    /// choices, or the topic's first decoding error.
    pub(crate) fn pick(mut self, topic: Option<&str>) -> Result<Topic, BagError> {
        let imu_topics = || self.listing(|t| t.imu, false);
        let (path, kind) = (self.path.clone(), self.kind);
        let i = match topic {
            None => {
                let imu: Vec<usize> = (0..self.list.len()).filter(|&i| self.list[i].imu).collect();
                match imu[..] {
                    [i] => i,
                    [] => return Err(BagError::NoImuTopic { path, kind, topics: self.listing(|_| true, true) }),
                    _ => return Err(BagError::SeveralImuTopics { path, kind, imu_topics: imu_topics() }),
                }
            }
            Some(name) => match self.list.iter().position(|t| t.name == name) {
                None => {
                    let topic = name.to_string();
                    return Err(BagError::TopicNotFound { path, kind, topic, imu_topics: imu_topics() });
                }
                Some(i) if !self.list[i].imu => {
                    let (topic, found) = (name.to_string(), self.list[i].other.clone().unwrap_or_default());
                    return Err(BagError::NotImu { path, kind, topic, found, imu_topics: imu_topics() });
                }
                Some(i) => i,
            },
        };
        let t = self.list.swap_remove(i);
        match t.error {
            Some(err) => Err(err),
            None => Ok(t),
        }
    }
}
