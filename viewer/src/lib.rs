//! MDG viewer (Vulkan).
