//! Splitting a dispatch over the adapter's limit of workgroups per
//! dimension (65,535 on most adapters): the x count stays under the limit
//! and y takes the rest; kernels rebuild the linear index from
//! `num_workgroups` and skip the items past the end.

/// Invocations per workgroup of every firn kernel (one warp on NVIDIA, two
/// on AMD's wave32, the WebGPU default limit's quarter).
pub const WORKGROUP_SIZE: u32 = 64;

/// Workgroup counts `(x, y, 1)` covering `items` invocations with at most
/// `limit` workgroups per dimension.
pub fn workgroups(items: u32, limit: u32) -> (u32, u32, u32) {
    let groups = items.div_ceil(WORKGROUP_SIZE).max(1);
    let x = groups.min(limit);
    (x, groups.div_ceil(x), 1)
}

/// Records a dispatch of `pipeline` over `items` invocations with bind
/// groups `groups` (group 0 first), split by [`workgroups`] within `limit`;
/// none when `items` is 0.
pub fn dispatch_items(
    pass: &mut wgpu::ComputePass,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
    items: u32,
    limit: u32,
) {
    if items == 0 {
        return;
    }
    pass.set_pipeline(pipeline);
    for (index, group) in groups.iter().enumerate() {
        pass.set_bind_group(index as u32, *group, &[]);
    }
    let (x, y, z) = workgroups(items, limit);
    pass.dispatch_workgroups(x, y, z);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatches_cover_every_item_within_the_limit() {
        for (items, limit) in [
            (1, 65_535),
            (64, 65_535),
            (65, 65_535),
            (1 << 24, 65_535),
            (1 << 22, 1_000),
        ] {
            let (x, y, z) = workgroups(items, limit);
            assert!(x <= limit && y <= limit && z == 1);
            assert!(u64::from(x) * u64::from(y) * u64::from(WORKGROUP_SIZE) >= u64::from(items));
            assert!(u64::from(x) * u64::from(y - 1) * u64::from(WORKGROUP_SIZE) < u64::from(items));
        }
    }
}
