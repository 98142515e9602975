//! What the summaries of `render` and `merge` share: the non-finite counts by stage.

use serde::Serialize;

#[derive(Serialize)]
pub struct StageCount {
    pub stage: String,
    pub count: u64,
}

pub fn stage_counts(v: &[(String, u64)]) -> Vec<StageCount> {
    v.iter()
        .map(|(stage, count)| StageCount {
            stage: stage.clone(),
            count: *count,
        })
        .collect()
}

pub fn write_nonfinite(
    f: &mut std::fmt::Formatter<'_>,
    total: u64,
    by_stage: &[StageCount],
) -> std::fmt::Result {
    let by_stage: Vec<String> = by_stage
        .iter()
        .map(|e| format!("{} {}", e.stage, e.count))
        .collect();
    writeln!(
        f,
        "non-finite     {total} values dropped ({})",
        by_stage.join(", ")
    )
}
