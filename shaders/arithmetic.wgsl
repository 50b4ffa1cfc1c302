// ---------------------------------------------------------------- exact-order arithmetic
// The built-in dot/length/normalize are lowered differently by Mesa's SPIR-V (Vulkan) and GLSL (GL)
// front ends, which changes the last bits and, after quantisation, a few pixels. Written out
// left to right they compile identically, so Vulkan and GL renders are bit-identical.

fn dot2(a: vec2<f32>, b: vec2<f32>) -> f32 { return a.x * b.x + a.y * b.y; }
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 { return a.x * b.x + a.y * b.y + a.z * b.z; }
fn len2(a: vec2<f32>) -> f32 { return sqrt(dot2(a, a)); }
fn len3(a: vec3<f32>) -> f32 { return sqrt(dot3(a, a)); }

