//! `brdfwave devices`: the Vulkan devices' names, one a line.

use anyhow::Result;

pub fn run() -> Result<()> {
    for name in brdfwave::vk::Context::list_devices()? {
        outln!("{name}")?;
    }
    Ok(())
}
