//! placeholder (the real loader is on branch `scene`)
#![allow(unused)]
pub fn load(_p: &std::path::Path) -> anyhow::Result<super::Scene> {
    anyhow::bail!("placeholder")
}
pub fn load_str(_s: &str, _p: &std::path::Path) -> anyhow::Result<super::Scene> {
    anyhow::bail!("placeholder")
}
