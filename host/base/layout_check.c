/* layout_check.c — compile-time checks of the structs shared with the kernels
 * (lib/shared_types.h): sizes and the offsets that padding could move. The device side is
 * checked at run time by tests/test_layout.c. */
#include "lib/shared_types.h"

#include <stddef.h>

_Static_assert(sizeof(ts_vec4) == 16, "ts_vec4 is 16 bytes");
_Static_assert(sizeof(ts_box) == 24, "ts_box is 24 bytes");
_Static_assert(sizeof(ts_box4) == 96, "ts_box4 is 96 bytes");
_Static_assert(sizeof(ts_tight4) == 24, "ts_tight4 is 24 bytes");
_Static_assert(sizeof(ts_qbvh_node) == 128, "ts_qbvh_node is 128 bytes");
_Static_assert(offsetof(ts_qbvh_node, child) == 96, "child[] follows the 24 box floats");
_Static_assert(offsetof(ts_qbvh_node, parent) == 112, "parent after child[4]");
_Static_assert(sizeof(ts_pair) == 8, "ts_pair is 8 bytes");
_Static_assert(sizeof(ts_segment) == 32, "ts_segment is 32 bytes");
_Static_assert(sizeof(ts_hit) == 20, "ts_hit is 20 bytes");
_Static_assert(offsetof(ts_hit, patch) == 12, "ts_hit.patch after t, u, v");
_Static_assert(sizeof(ts_patch_attr) == 160, "ts_patch_attr is 160 bytes");
_Static_assert(offsetof(ts_patch_attr, st) == 96, "st after the texture fields");
_Static_assert(offsetof(ts_patch_attr, metallic) == 128, "the principled fields after st");
_Static_assert(offsetof(ts_patch_attr, trim_count) == 156,
               "seven principled floats, then trim_count");
_Static_assert(sizeof(ts_texture) == 80, "ts_texture is 80 bytes");
_Static_assert(sizeof(ts_light) == 112, "ts_light is 112 bytes");
_Static_assert(offsetof(ts_light, pos) == 64, "pos after the 64 bytes of distant and dome");
_Static_assert(sizeof(ts_emitter) == 16, "ts_emitter is 16 bytes");
_Static_assert(offsetof(ts_patch_attr, disp_amplitude) == 24,
               "displacement after colour, flags, kind, octaves");
_Static_assert(sizeof(ts_xform) == 48, "ts_xform is 48 bytes");
_Static_assert(sizeof(ts_camera_params) == 272, "ts_camera_params is 272 bytes");
_Static_assert(offsetof(ts_camera_params, width) == 64, "width after four float[4]");
_Static_assert(offsetof(ts_camera_params, moving) == 96, "moving after the 96 bytes");
_Static_assert(offsetof(ts_camera_params, origin1) == 112, "shutter close after moving, pad");
_Static_assert(offsetof(ts_camera_params, crop_x) == 176, "the crop after shutter close");
_Static_assert(offsetof(ts_camera_params, lens_x) == 192, "the lens after the crop");
_Static_assert(sizeof(ts_shade_params) == 32, "ts_shade_params is 32 bytes");
_Static_assert(sizeof(ts_bake_params) == 48, "ts_bake_params is 48 bytes");
_Static_assert(offsetof(ts_bake_params, eye) == 32, "eye after eight words");
_Static_assert(sizeof(ts_relight_params) == 48, "ts_relight_params is 48 bytes");
_Static_assert(offsetof(ts_relight_params, uniform) == 16, "uniform after four words");

/* Keeps the translation unit non-empty for strict compilers. */
int ts_layout_checked(void)
{
    return 1;
}
