//! The window's graphics: a surface, the adapter that can present to it
//! (best first, as `firn info` ranks them), one device shared by the
//! drawing and a GPU simulation, and the egui renderer.

use std::sync::Arc;

use firn_gpu::{AdapterReport, GpuContext};
use winit::window::Window;

use crate::error::ViewError;

/// The surface and the device that draws into it.
pub struct Graphics {
    /// The window's surface.
    pub surface: wgpu::Surface<'static>,
    /// Its configuration (size, format, present mode).
    pub config: wgpu::SurfaceConfiguration,
    /// The device, shared with a simulation on the GPU.
    pub context: Arc<GpuContext>,
}

impl Graphics {
    /// Opens the best adapter that can present to `window`.
    pub fn new(window: Arc<Window>) -> Result<Graphics, ViewError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let surface = instance
            .create_surface(Arc::clone(&window))
            .map_err(|error| ViewError::NoAdapter {
                reason: format!("no surface for the window: {error}"),
            })?;
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
        let presenting: Vec<wgpu::Adapter> = adapters
            .into_iter()
            .filter(|adapter| adapter.is_surface_supported(&surface))
            .collect();
        let adapter = firn_gpu::context::rank_adapters(presenting)
            .into_iter()
            .next()
            .ok_or_else(|| ViewError::NoAdapter {
                reason: "none of the adapters found can present to a window".into(),
            })?;
        let context = GpuContext::open(&adapter).map_err(|error| ViewError::NoAdapter {
            reason: error.to_string(),
        })?;
        let size = window.inner_size();
        let config = surface_config(&surface, &adapter, size.width, size.height);
        surface.configure(&context.device, &config);
        Ok(Graphics {
            surface,
            config,
            context,
        })
    }

    /// What the device runs on.
    pub fn adapter(&self) -> &AdapterReport {
        &self.context.adapter
    }

    /// Follows a resized window.
    pub fn resize(&mut self, width: u32, height: u32) {
        if width > 0 && height > 0 {
            self.config.width = width;
            self.config.height = height;
            self.surface.configure(&self.context.device, &self.config);
        }
    }

    /// Re-applies the configuration (after the surface was lost or outdated).
    pub fn reconfigure(&self) {
        self.surface.configure(&self.context.device, &self.config);
    }

    /// The next texture to draw into, or `None` to skip this frame.
    pub fn next_texture(&self) -> Option<wgpu::SurfaceTexture> {
        match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(texture)
            | wgpu::CurrentSurfaceTexture::Suboptimal(texture) => Some(texture),
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.reconfigure();
                None
            }
            _ => None,
        }
    }

    /// An offscreen target like the surface's textures, for screenshots.
    pub fn capture_target(&self) -> wgpu::Texture {
        self.context
            .device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("screenshot"),
                size: wgpu::Extent3d {
                    width: self.config.width,
                    height: self.config.height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: self.config.format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
    }
}

/// An sRGB format (so shaders write linear colour), vsync where offered.
fn surface_config(
    surface: &wgpu::Surface<'_>,
    adapter: &wgpu::Adapter,
    width: u32,
    height: u32,
) -> wgpu::SurfaceConfiguration {
    let capabilities = surface.get_capabilities(adapter);
    let format = capabilities
        .formats
        .iter()
        .copied()
        .find(wgpu::TextureFormat::is_srgb)
        .unwrap_or(capabilities.formats[0]);
    wgpu::SurfaceConfiguration {
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        format,
        color_space: wgpu::SurfaceColorSpace::Auto,
        width: width.max(1),
        height: height.max(1),
        present_mode: wgpu::PresentMode::AutoVsync,
        desired_maximum_frame_latency: 2,
        alpha_mode: capabilities.alpha_modes[0],
        view_formats: vec![],
    }
}
