//! A stage's input and output in memory (the Python module's way to run
//! a stage on a cloud it holds).

use crate::cloud::Cloud;

/// A stage's input and output in memory: [`super::IoArgs::read`] takes `input`
/// (as the stage selects nothing, every attribute is there already) and
/// [`super::IoArgs::write`] leaves the result in `output`.
#[derive(Clone, Debug, Default)]
pub struct Memory(pub std::sync::Arc<std::sync::Mutex<MemoryIo>>);

/// What [`Memory`] holds.
#[derive(Debug, Default)]
pub struct MemoryIo {
    pub input: Option<Cloud>,
    pub output: Option<Cloud>,
}

impl Memory {
    /// A stage's input, for [`super::IoArgs::memory`].
    pub fn with_input(cloud: Cloud) -> Memory {
        Memory(std::sync::Arc::new(std::sync::Mutex::new(MemoryIo {
            input: Some(cloud),
            output: None,
        })))
    }

    /// The output the stage wrote, if it did.
    pub fn take_output(&self) -> Option<Cloud> {
        self.0.lock().ok()?.output.take()
    }

    pub(super) fn take_input(&self) -> Option<Cloud> {
        self.0.lock().ok()?.input.take()
    }
}
