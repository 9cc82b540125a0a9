//! Why the viewer could not open or had to stop, with what to do about it.

use thiserror::Error;

/// What went wrong in `firn view`.
#[derive(Debug, Error)]
pub enum ViewError {
    /// The scene, run directory or an option is bad (exit 2).
    #[error("{0}")]
    BadInput(String),
    /// There is no display to open a window on (exit 2).
    #[error(
        "firn view needs a display, and none could be opened ({reason})\n  \
         fix: run it on a desktop, or under a virtual display (xvfb-run firn view ...); \
         for headless work use `firn run SCENE`, which writes caches, pictures and animations"
    )]
    NoDisplay {
        /// What the windowing system said.
        reason: String,
    },
    /// No graphics adapter can draw into the window (exit 2).
    #[error(
        "firn view found no graphics adapter that can draw into its window ({reason})\n  \
         fix: install a Vulkan, Metal or DX12 driver (Debian/Ubuntu without a GPU: \
         apt install mesa-vulkan-drivers libvulkan1); for headless work use `firn run SCENE`"
    )]
    NoAdapter {
        /// What was tried.
        reason: String,
    },
    /// Something failed while running (exit 1).
    #[error("{0}")]
    Failed(String),
}
