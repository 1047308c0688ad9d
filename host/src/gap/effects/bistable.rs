//! stub
use super::{EffectFit, TrainingData};
pub(super) fn bistable(_d: &TrainingData) -> Option<EffectFit> {
    None
}
