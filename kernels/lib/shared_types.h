/* shared_types.h — every struct and constant the host and the kernels exchange.
 *
 * Included by the C11 host (the .c files under host/) and by every OpenCL C 1.2 kernel. Rules
 * (STYLE.md 1-2): fixed-width scalars only, vectors as named float fields (never float3: 12 bytes
 * on the host, 16 on the device), explicit padding, no bool/size_t/pointers. Sizes and offsets are
 * checked with _Static_assert in host/base/layout_check.c and against the device by
 * tests/test_layout.c, which runs a kernel writing sizeof/offsetof back.
 */
#ifndef TS_SHARED_TYPES_H
#define TS_SHARED_TYPES_H

#ifdef __OPENCL_C_VERSION__
typedef uint ts_u32;
typedef int ts_i32;
typedef uchar ts_u8;
#define TS_GLOBAL __global
#define TS_CONST_GLOBAL __global const
#define TS_INLINE inline
/* A table of constants at program scope (lib/principled_table.h). */
#define TS_CONSTANT_TABLE __constant
/* A small helper of a hot loop that PoCL's compiler would call out of line (group_enter and
 * slab4 in bottom_level, cull_enter in top_level, the leaf's tight box and store in build: 5%
 * of the displaced teapot's render, docs/benchmarks.md). */
#ifdef __OPTIMIZE__
#define TS_INLINE_ALWAYS __attribute__((always_inline)) inline
#else /* -cl-opt-disable (Oclgrind, whose interpreter lacks the intrinsics inlining adds) */
#define TS_INLINE_ALWAYS inline
#endif
#else
#include <stdint.h>
/* Type-generic maths, as in OpenCL C: fabs, floor, fmin, sqrt... of a float stay in float,
 * so the shared helpers round the same on host and device. */
#include <tgmath.h>
typedef uint32_t ts_u32;
typedef int32_t ts_i32;
typedef uint8_t ts_u8;
#define TS_GLOBAL
#define TS_CONST_GLOBAL const
#define TS_INLINE static inline
#define TS_INLINE_ALWAYS static inline
#define TS_CONSTANT_TABLE static const
#endif

/* Work-group size of every launch (one size, so PoCL compiles each kernel once); the
 * work-group leaf intersection sizes its local memory by it. */
#define TS_GROUP_SIZE 64

/* Leaves a work-item of `build_leaves` builds on CPU devices (build.cl, -DTS_CPU_LANES; fewer
 * in a tree of fewer leaves): two 2 x 2 blocks, each built a leaf per float4 lane with the noise
 * cells of its displacement intervals sharing the float8 lanes, which are SIMD registers there
 * (four leaves a work-item: 5% slower on forest-100's squeezed frames; sixteen: no faster).
 * Elsewhere (GPUs, where a float8 is eight scalar operations and private arrays cost
 * registers) one leaf. A launch over a tree run has 4^m / min(4^m, run) work-items a tree
 * (trace.c build_leaf_items). */
#define TS_BUILD_LEAF_RUN 8u

/* Vertices a work-item of `dice` evaluates (dice.cl: two, displace_value_pair's points): a
 * launch over a tree run has ceil((2^m + 1)^2 / TS_DICE_VERTICES) work-items a tree. */
#define TS_DICE_VERTICES 2u

/* Hard ceiling on the level of detail: 4^10 micro-quads per patch (Hanika §4 uses m <= 10).
 * Kernel stacks are sized from it. */
#define TS_LOD_LIMIT 10
/* Marks an unused pair or a finished traversal. */
#define TS_INVALID 0xffffffffu
/* Top-level traversal state: (node << 3) | next position in the ray's child order.
 * 0 = root, position 0 (a fresh ray); TS_INVALID = traversal finished. */
#define TS_ENTRY_START 0u
#define TS_CHILD_EMPTY ((ts_i32)0x80000000)

/* Four floats; w carries a per-field extra (see each use). 16 bytes. */
typedef struct ts_vec4 {
    float x, y, z, w;
} ts_vec4;

/* Axis-aligned box, 24 bytes. Empty boxes have lo > hi. */
typedef struct ts_box {
    float lo_x, lo_y, lo_z;
    float hi_x, hi_y, hi_z;
} ts_box;

/* Four sibling boxes of a patch's implicit quad-tree (nodes 4g..4g+3 of one level), stored
 * SoA so one float4 slab test covers all four children (lib/quadtree.h). 96 bytes. */
typedef struct ts_box4 {
    float lo_x[4], lo_y[4], lo_z[4];
    float hi_x[4], hi_y[4], hi_z[4];
} ts_box4;

/* The tight boxes of a ts_box4's four nodes, in the arena `tight` beside `groups` (the same
 * index): each node's box of its diced vertices (the micro-quads' tight_leaf_box, and unions
 * of them), as 8-bit codes inside the node's box. Face lo_x of lane q is
 * box.lo_x[q] + lo_x[q] * step, hi_x is box.hi_x[q] - hi_x[q] * step, with step =
 * (box.hi_x[q] - box.lo_x[q]) / 255 (lib/quadtree.h box4_tight_lane). A ray leaving the patch,
 * traced as micro-triangles (the origin-patch rule, bottom_level.cl), is culled by these in box
 * mode: its triangles lie in them, and box mode's boxes, which bound every finer dicing, are
 * far larger on a rough surface. 24 bytes. */
typedef struct ts_tight4 {
    ts_u8 lo_x[4], lo_y[4], lo_z[4];
    ts_u8 hi_x[4], hi_y[4], hi_z[4];
} ts_tight4;

/* Top-level culling by a built patch's upper quad-tree levels (top_level.cl, build.cl
 * build_cull): TS_CULL_GROUPS sibling groups per patch, its tree's level 1 (group 0) and
 * level 2 (group 1 + c: the children of level-1 node c), copied from the tree when it is
 * built as 8-bit codes inside the patch's top-level box (ts_tight4, the trees' tight codes'
 * rounding: decoded, each box holds the tree's); a candidate whose ray enters none of them
 * within [0, tmax] could not reach a leaf, so it is not emitted. 120 bytes per patch. */
#define TS_CULL_GROUPS 5u

/* One node of the top-level 4-wide BVH (Hanika §3.1, Dammertz et al. 2008), 128 bytes.
 * child[i] >= 0: inner node index; child[i] < 0 and != TS_CHILD_EMPTY: a leaf holding
 * patch ~child[i]; TS_CHILD_EMPTY: no child (its box is empty).
 * Children 0,1 lie below children 2,3 along axis (axes & 3); child 0 below 1 along
 * ((axes >> 2) & 3); child 2 below 3 along ((axes >> 4) & 3). Ordered traversal visits
 * them front to back by the signs of the ray direction on those axes, which is what lets
 * a ray resume from a saved (node, position). */
typedef struct ts_qbvh_node {
    float lo_x[4], lo_y[4], lo_z[4];
    float hi_x[4], hi_y[4], hi_z[4];
    ts_i32 child[4];
    ts_i32 parent;      /* -1 at the root */
    ts_u32 axes;        /* three 2-bit split axes, see above */
    ts_u32 parent_slot; /* which child of the parent this node is (0..3) */
    ts_u32 pad;
} ts_qbvh_node;

/* A (leaf, ray) candidate produced by top_level and sorted by leaf (Hanika Fig. 2).
 * window = active_index * n_per_ray + k: where the candidate was written, which names the
 * ray (window / n_per_ray) and the per-candidate hit record. 8 bytes. */
typedef struct ts_pair {
    ts_u32 leaf;
    ts_u32 window;
} ts_pair;

/* The pairs of one patch after sort: [begin, end) in the sorted pair array, and where
 * the patch is diced in the batch's arenas (patch slots of variable size, DESIGN.md §1).
 * A moving patch has two grids and two trees, time 0 then time 1. shape: the patch whose
 * grid and tree these are, diced from its control points: `patch` itself, or the master
 * patch an instance shares its dicing with (ObjectInstance, host/scene/instance.c), whose
 * frame bottom_level moves the ray into by the instance's transform. 32 bytes. */
typedef struct ts_segment {
    ts_u32 patch;
    ts_u32 begin, end;
    ts_u32 lod;         /* m: (2^m+1)^2 vertices, 4^m micro-quads */
    ts_u32 vert_first;  /* first vertex of its grid(s) in the vertex arena */
    ts_u32 group_first; /* first sibling group of its tree(s) in the group arena */
    ts_u32 flags;       /* TS_PATCH_MOVING: two time samples; TS_PATCH_ROUGH */
    ts_u32 shape;       /* the patch diced: patch, or the master an instance shares */
} ts_segment;

/* One tree of a batch for the dice and build kernels: (segment index << 1) | time. The
 * host lists a batch's trees by decreasing m, so the trees deeper than a level are a
 * prefix of the list (one launch per level, no idle work-items). */
#define TS_TREE_SEGMENT(t) ((t) >> 1)
#define TS_TREE_TIME(t) ((t)&1u)

/* Closest hit of one ray against one patch (bottom_level), or of the ray overall
 * (resolve). t = TS_NO_HIT when nothing was hit. prim = TS_PRIM(m, index): the LOD the
 * patch was diced at and the micro-triangle (2 * quad + 0/1, exact mode) or leaf box
 * (2 * quad, box mode) hit, quad = j * 2^m + i. u, v: patch parameters at the hit. 20 bytes. */
#define TS_PRIM(m, index) (((m) << 24) | (index))
#define TS_PRIM_LOD(prim) ((prim) >> 24)
#define TS_PRIM_INDEX(prim) ((prim)&0xffffffu)
typedef struct ts_hit {
    float t, u, v;
    ts_u32 patch, prim;
} ts_hit;

/* Displacement functions (DESIGN.md §2, RIB `Displacement "name" ...`). Each bounds its
 * value by a conservative interval (lib/displace.h). */
#define TS_DISP_NONE 0u
#define TS_DISP_FBM 1u     /* fractal Brownian motion of gradient noise, object space */
#define TS_DISP_RIDGED 2u  /* ridged fBm: sum of gain^o * (1 - 2|noise|) */
#define TS_DISP_TEXTURE 3u /* amplitude * (texel - offset): an image texture at the patch's st */

/* ts_patch_attr.flags */
#define TS_PATCH_MOVING 1u /* has a second time sample (scene cp1), Hanika §3.4 */
/* ts_segment.flags only: the patch diced is displaced by several micro-quads at its level
 * (host/scene/scene.c scene_patch_rough), so in box mode its trees get tight codes
 * (ts_tight4) and the rays leaving it are culled by them; elsewhere box mode's boxes are
 * near the boxes of the vertices already and the codes stay 0 (the node boxes). */
#define TS_PATCH_ROUGH 2u
/* ts_segment.flags bits 16-31, triangle mode only (lib/quadtree.h quadtree_stitch): for each
 * edge k of the patch diced (0: v = 0, 1: u = 0, 2: u = 1, 3: v = 1), 4 bits from bit
 * 16 + 4k, how many levels coarser the patch across it is diced; 0 everywhere else. */
#define TS_SEG_EDGE_SHIFT 16u
/* ts_segment.flags only: the patch diced is trimmed (ts_patch_attr.trim_count > 0): build
 * gives the micro-quads its trim curves remove empty boxes, and bottom_level tests a
 * micro-quad's triangles only where its box is not empty (lib/trim.h). */
#define TS_SEG_TRIMMED 4u
/* ts_segment.flags only: the segment has no tree in the arenas; bottom_level traces its pairs
 * through the kept skeleton of the patch's tree (levels 1 .. m - 2 as codes, build.cl
 * build_skeleton) and makes the 4 x 4 blocks of leaves its rays enter, or the blocks' vertices
 * for the rays that leave the patch (bottom_level.cl bl_skeleton): where a pass meets a patch
 * that does not fit with few rays. */
#define TS_SEG_SKELETON 8u
/* The levels of leaves below a skeleton: it keeps levels 1 .. m - TS_SKELETON_DROP of a tree,
 * and bottom_level makes the leaves of its nodes of level m - TS_SKELETON_DROP (blocks of
 * 2^DROP x 2^DROP leaves). */
#define TS_SKELETON_DROP 2u
/* The coarsest m whose trees keep a skeleton. */
#define TS_SKELETON_MIN_LOD 4u
/* Sibling groups of a tree of depth m that its skeleton keeps. */
#define TS_SKELETON_GROUPS(m) (quadtree_group_offset((m) + 1u - TS_SKELETON_DROP) - 1u)
#define TS_PATCH_COLOR_TEX 2u /* Cs is multiplied by texture color_tex at the hit's st */
/* Casts no shadow: shadow rays (TS_RAY_SHADOW) pass through the patch, which top_level leaves
 * out of their candidates; every other ray sees it (RIB Attribute "visibility"
 * "transmission" 0, BMRT's Attribute "render" "casts_shadows" "none"). */
#define TS_PATCH_NO_SHADOW 4u
/* Unseen by the camera: eye rays (ray field from 0, not shadow rays) pass through the patch,
 * which top_level leaves out of their candidates; every other ray sees it (RIB Attribute
 * "visibility" "camera" 0, as RenderMan scenes hide their lights' cards). */
#define TS_PATCH_NO_CAMERA 8u
/* Unseen by indirect rays: the BSDF rays of a bounce (ray field from > 0, not shadow rays)
 * pass through the patch; an emissive one is then lit only by light sampling, whose sample
 * counts whole (shade.cl shade_direct_light: no BSDF sample can find it) (RIB Attribute
 * "visibility" "indirect" 0). */
#define TS_PATCH_NO_INDIRECT 16u
/* Cut out (RIS `presence` from a texture): a micro-quad whose centre has a mask value below 0.5
 * is not there (build gives it an empty box, as a trim does: lib/texture.h tex_cutout_keeps).
 * The mask is texture color_tex at the point's st, its alpha (texel w), or with
 * TS_PATCH_CUTOUT_RED its first channel; Cs is multiplied by the same texture only when
 * TS_PATCH_COLOR_TEX is set too. */
#define TS_PATCH_CUTOUT 32u
#define TS_PATCH_CUTOUT_RED 64u

/* Materials (RIB Surface), with the patch colour Cs. */
#define TS_MAT_MATTE 0u   /* Lambertian, albedo Kd * Cs */
#define TS_MAT_PLASTIC 1u /* Kd * Cs / pi plus a GGX lobe of albedo <= Ks, alpha = roughness */
#define TS_MAT_METAL 2u   /* a GGX lobe of albedo <= Ks * Cs (coloured), alpha = roughness; no Kd */
#define TS_MAT_GLASS                                                                               \
    3u /* a smooth dielectric of index ior: Fresnel reflection, and refraction                     \
          tinted by Cs (lib/bsdf.h glass_sample) */
#define TS_MAT_PRINCIPLED                                                                          \
    4u /* Burley 2012's principled BRDF, base colour Cs, GGX alpha = roughness, the metallic ...   \
          clearcoat_gloss fields; layered so that it never reflects more than it receives          \
          (lib/principled.h) */
#define TS_MAT_TRANSLUCENT                                                                         \
    5u /* a thin sheet, Lambertian on both sides: Kd * Cs / pi reflected, Ks * Cs / pi             \
          transmitted to the far side (diffuse transmission; no medium: lib/bsdf.h                 \
          translucent_eval) */

/* Per-patch attributes from the scene, 160 bytes.
 * Displacement d(P) moves a surface point along its displacement normal (the bilinear
 * interpolation of the patch's corner normals, scene corner_n); the noise is evaluated at
 * the object-space position world_to_object(P), the transform of scene xform[xform].
 * TS_DISP_TEXTURE: d = disp_amplitude * (texel - disp_offset), the texel of texture
 * disp_tex at the point's texture coordinates (lib/texture.h).
 * Texture coordinates (s, t) at (u, v): the bilinear interpolation of st[] at the corners
 * (0,0), (1,0), (0,1), (1,1) (RIB "st", default the corners' (u, v)).
 * Emission (RIB AreaLightSource): radiance le_* leaves both sides of the patch. */
typedef struct ts_patch_attr {
    float cs_r, cs_g, cs_b;
    ts_u32 flags;
    ts_u32 disp_kind;        /* TS_DISP_* */
    ts_u32 disp_octaves;     /* >= 1 */
    float disp_amplitude;    /* world units */
    float disp_frequency;    /* of the first octave, per object-space unit */
    float disp_lacunarity;   /* frequency ratio between octaves (default 2) */
    float disp_gain;         /* amplitude ratio between octaves (default 0.5) */
    ts_u32 xform;            /* index of the patch's world-to-object transform */
    ts_u32 material;         /* TS_MAT_* */
    float kd, ks, roughness; /* diffuse and specular (translucent: transmitted) weights, alpha */
    ts_u32 emitter;          /* index in the emitter table, TS_INVALID if it does not emit */
    float le_r, le_g, le_b;  /* emitted radiance */
    ts_u32 color_tex;        /* texture multiplying Cs when flags has TS_PATCH_COLOR_TEX */
    ts_u32 disp_tex;         /* TS_DISP_TEXTURE: the displacement texture */
    float disp_offset;       /* TS_DISP_TEXTURE: texel value of zero displacement */
    float ior;               /* TS_MAT_GLASS: index of refraction inside (outside: 1); else 0 */
    ts_u32 trim_first;       /* a trimmed NURBS piece (lib/trim.h): its trim_count segments */
    float st[8];             /* (s, t) at the four corners, in corner order */
    /* TS_MAT_PRINCIPLED (lib/principled.h), each in [0, 1] (clearcoat [0, 4]); 0 for the other
     * materials */
    float metallic;        /* blend from the dielectric (0) to the conductor (1) response */
    float specular;        /* the dielectric's F0 = 0.08 specular */
    float specular_tint;   /* blend of that F0 from white towards the base colour's hue */
    float sheen;           /* the grazing sheen lobe's weight */
    float sheen_tint;      /* blend of the sheen from white towards the base colour's hue */
    float clearcoat;       /* the clear coat: 0.25 clearcoat F D G / (4 cos cos), F0 0.04 */
    float clearcoat_gloss; /* the coat's GGX alpha from 0.1 (0) to 0.01 (1) */
    ts_u32 trim_count;     /* segments of the scene's trim_seg from trim_first; 0: untrimmed */
} ts_patch_attr;

/* Lights (DESIGN.md §3). One light is chosen per light sample, with probability proportional
 * to its weight (lib/lights.h light_select); a uniform dome takes part only when BSDF
 * sampling cannot find it (--sampling light). */
#define TS_LIGHT_DISTANT 0u /* the sun: a cone of directions around dir (delta: cos_max = 1) */
#define TS_LIGHT_DOME 1u    /* uniform sky radiance from every direction */
#define TS_LIGHT_AREA 2u    /* every emissive patch, chosen by area (the emitter table) */
#define TS_LIGHT_POINT 3u   /* RenderMan pointlight: a delta light at pos, I falloff(d) */
#define TS_LIGHT_SPOT 4u    /* RenderMan spotlight: a point light times its cone and beam */

/* ts_light.flags */
#define TS_LIGHT_NOT_SEEN 1u /* eye rays that miss do not see this dome (RIB ambientlight) */

/* 112 bytes. Point and spot lights (RI Spec 3.2 Appendix A, pointlight and spotlight): the
 * irradiance on a surface facing the light at distance d is radiance * falloff(d), falloff(d)
 * = (falloff_dist / max(d, falloff_min))^falloff (1 / d^2 for RenderMan's lights), times for
 * a spot cos^beam(a) smoothstep(cos_max, cos_inner, cos(a)), a the angle between the axis and
 * the direction from the light, and nothing where cos(a) < cos_max. */
typedef struct ts_light {
    ts_u32 type;
    ts_u32 emitter_count; /* area: entries of the emitter table */
    float cos_max;        /* distant: cosine of the cone's half angle, 1 = delta; spot:
                             cos(coneangle) */
    float solid_angle;    /* distant: of the cone (0 for a delta) */
    float dir[4];         /* distant: unit vector towards the light; spot: the unit axis, away
                             from the light */
    float radiance[4];    /* distant: radiance in the cone, or irradiance E for a delta; dome: L
                             (times the map's texel when it has one); point, spot: intensity *
                             lightcolor, the irradiance where falloff(d) = 1 */
    ts_u32 map_width, map_height; /* dome: its lat-long map, 0 x 0 for a uniform sky */
    float weight;    /* how much light it brings to a white matte point facing it, unoccluded (its
                        luminance): the light-selection weight (host/pipeline/lights.c) */
    ts_u32 flags;    /* TS_LIGHT_NOT_SEEN */
    float pos[4];    /* point, spot: the position, world space; w unused */
    float cos_inner; /* spot: cos(coneangle - conedeltaangle): full strength inside */
    float beam;      /* spot: beamdistribution, the exponent of cos(a) */
    float falloff;   /* point, spot: the exponent of the distance falloff (2: 1 / d^2) */
    float falloff_dist; /* point, spot: the distance where falloff(d) = 1 */
    float falloff_min;  /* point, spot: nearer than this the falloff stays at its value there */
    ts_u32 pad[3];
} ts_light;

/* An emissive patch for light sampling: chosen with probability prob (by area), then
 * (u, v) uniform. 16 bytes. */
typedef struct ts_emitter {
    ts_u32 patch;
    float cdf;  /* cumulative probability up to and including this entry */
    float prob; /* probability of choosing this entry */
    float area; /* approximate area, world units^2 */
} ts_emitter;

/* An affine world-to-object transform: rows of a 3x4 matrix (x' = r0 . (x, y, z, 1)).
 * 48 bytes. */
typedef struct ts_xform {
    float r0[4], r1[4], r2[4];
} ts_xform;

/* Image textures (lib/texture.h, docs/rendering.md). Each level of a texture is split into
 * tiles of TS_TEX_TILE x TS_TEX_TILE texels (row-major in the level); tile (tx, ty) of level
 * k is page level_page[k] + ty * ceil(width_k / TS_TEX_TILE) + tx of the page table, whose
 * entry names the slot of the tile pool holding it (TS_INVALID: not resident). A slot is
 * TS_TEX_TILE^2 ts_vec4 texels, row-major. width_k = ceil(width / 2^k).
 * TS_TEX_MINMAX: x = the minimum, y = the maximum of the first channel over the level-0
 * texels the texel covers (level 0: x = y = the value); levels down to 1 x 1.
 * TS_TEX_RGB: xyz = colour, w = alpha (1 without an alpha channel), level 0 only. */
#define TS_TEX_TILE_LOG2 5u
#define TS_TEX_TILE (1u << TS_TEX_TILE_LOG2)
#define TS_TEX_MAX_LEVELS 16u /* up to 32768 texels a side */
#define TS_TEX_MINMAX 0u
#define TS_TEX_RGB 1u

/* 80 bytes. */
typedef struct ts_texture {
    ts_u32 width, height;
    ts_u32 levels; /* 1 + ceil(log2(max(width, height))) for TS_TEX_MINMAX, 1 for TS_TEX_RGB */
    ts_u32 kind;   /* TS_TEX_* */
    ts_u32 level_page[TS_TEX_MAX_LEVELS];
} ts_texture;

/* Projections of the camera (ts_camera_params.projection, RIB Projection). */
#define TS_PROJECTION_PERSPECTIVE 0u
#define TS_PROJECTION_ORTHOGRAPHIC 1u

/* Everything the camera kernel needs, in world space. 272 bytes.
 * Ray through raster point (px, py): screen (sx, sy) in [-1, 1]^2, y up. Perspective:
 * from origin, direction sx * right + sy * up + forward (RenderMan: x right, y up, looking
 * down +z; forward holds the screen window's centre). Orthographic: from origin + sx *
 * right + sy * up, direction forward (unit). A moving camera (RIB MotionBegin around the
 * camera transformation) has the same four vectors at shutter close in origin1 ... forward1:
 * a ray of time t uses (1 - t) v + t v1 for each, as if the camera's matrix were interpolated
 * linearly, the way moving patches interpolate their points (Hanika §3.4). The image may be a
 * part of the frame (RIB CropWindow): its width x height pixels are the frame's from column
 * crop_x and row crop_y on, the frame full_width x full_height pixels; a pixel's ray and its
 * sample values are the frame's (pixel key (crop_y + y) full_width + crop_x + x), so the part
 * has the whole frame's pixels. full_width 0: the image is the frame (the host fills it in,
 * pipeline_camera). A thin lens (RIB DepthOfField, dof 1): the ray of a pinhole direction d
 * (its camera-space depth 1) starts at a point of the lens, eye + a lens_x + b lens_y for a
 * point (a, b) of the unit disk (lens_x, lens_y: the camera's unit x and y axes times the lens
 * radius focallength / (2 fstop)), and passes through eye + focal d, where the plane of focus
 * lies at camera-space depth focal; its direction is again of depth 1, (eye + focal d - start)
 * / focal. */
typedef struct ts_camera_params {
    float origin[4];  /* eye position, w unused */
    float right[4];   /* camera x axis in world space, scaled by the screen half-width */
    float up[4];      /* camera y axis, scaled by the screen half-height */
    float forward[4]; /* camera z axis (unit) */
    ts_u32 width, height;
    ts_u32 spp, seed;
    ts_u32 first_sample; /* index of the wave's first sample in the frame's order */
    ts_u32 ray_count;    /* rays in this wave */
    ts_u32 projection;   /* TS_PROJECTION_* */
    ts_u32 band;         /* pixels a band of the sample order (lib/sample_order.h); 0: one */
    ts_u32 moving;       /* 1: the camera moves (origin1 ... forward1 at shutter close) */
    ts_u32 clip;         /* 1: eye rays see only depths in [clip_near, clip_far] (RIB Clipping) */
    float clip_near, clip_far; /* camera-space depths (distance along forward) */
    float origin1[4], right1[4], up1[4], forward1[4]; /* at shutter close; 0 when static */
    ts_u32 crop_x, crop_y;          /* the image's first column and row in the frame */
    ts_u32 full_width, full_height; /* the frame's pixels */
    float lens_x[4], lens_y[4];     /* the lens's half-axes (dof), w unused */
    float lens_x1[4], lens_y1[4];   /* at shutter close (dof and moving) */
    ts_u32 dof;                     /* 1: a thin lens; 0: a pinhole */
    float focal;                    /* the plane of focus's camera-space depth (dof) */
    ts_u32 pad2[2];
} ts_camera_params;

/* A divisor d made ready for division by multiplication (lib/udiv.h udiv: n / d =
 * (t + ((n - t) >> sh1)) >> sh2 with t the high word of mul n, exact for every 32-bit n;
 * Granlund and Montgomery 1994, Fig. 4.1). 16 bytes. */
typedef struct ts_udiv {
    ts_u32 mul, sh1, sh2;
    ts_u32 d;
} ts_udiv;

/* The frame's sample order (lib/sample_order.h) with its divisions made ready, for the
 * kernels that find the pixel and sample of each of a wave's samples (camera, shade; the
 * host's sample_order_divs). 80 bytes. */
typedef struct ts_order_divs {
    ts_udiv band_samples; /* a band's samples: band x spp */
    ts_udiv band;         /* a band's pixels */
    ts_udiv last;         /* the last band's pixels (npix - its first pixel) */
    ts_udiv width;        /* the image's width: a pixel's row */
    ts_u32 mask;          /* lib/sampler.h sampler_mask(spp) */
    ts_u32 npix;          /* the frame's pixels */
    ts_u32 pad[2];
} ts_order_divs;

/* Light sampling vs BSDF sampling at each path vertex (ts_shade_params.sampling). */
#define TS_SAMPLING_MIS 0u   /* both at every vertex, combined by MIS (balance heuristic) */
#define TS_SAMPLING_LIGHT 1u /* light sampling only (next-event estimation) */
#define TS_SAMPLING_BSDF 2u  /* BSDF sampling only */

/* Parameters of the shade stage for one bounce. 32 bytes. */
typedef struct ts_shade_params {
    ts_u32 light_count;
    ts_u32 bounce;   /* 0: the eye rays' hits */
    ts_u32 depth;    /* path vertices that scatter: bounce < depth; bounce == depth only
                        collects emission */
    ts_u32 sampling; /* TS_SAMPLING_* */
    ts_u32 seed;
    ts_u32 spp;  /* samples per pixel, and */
    ts_u32 band; /* pixels a band of the sample order (0: one): the host makes them ready as
                    the kernel's ts_order_divs (pipeline_shade), which shade reads instead */
    ts_u32 pad;
} ts_shade_params;

/* The bake (`tessera bake`, kernels/bake.cl, docs/bake.md): ts_bake_params.flags. */
#define TS_BAKE_COSINE 1u /* V times max(0, n . w); directions cosine-weighted about n */
#define TS_BAKE_SPHERE                                                                             \
    2u /* directions uniform over the whole sphere (below the surface: V = 0,                      \
          not traced) instead of the hemisphere about n */
#define TS_BAKE_FRONT                                                                              \
    4u /* n is the patch's own normal (dP/du x dP/dv), not turned towards                          \
          the camera */

/* One wave of bake points: points [first_point, first_point + point_count) of the global
 * point list (patches in order, each patch's (2^m+1)^2 vertices row by row), each with
 * `rays` rays. 48 bytes. */
typedef struct ts_bake_params {
    ts_u32 first_point;
    ts_u32 point_count;
    ts_u32 rays;  /* N rays per point */
    ts_u32 bands; /* B = 1..4: B^2 coefficients per point (lib/sh.h) */
    ts_u32 flags; /* TS_BAKE_* */
    ts_u32 seed;
    ts_u32 patch_count;
    ts_u32 orthographic; /* 1: eye[0..2] is the camera's forward direction */
    float eye[4];        /* the camera position (perspective), w unused */
} ts_bake_params;

/* Relighting with a baked occlusion (`render --occlusion`, lib/relight.h, docs/bake.md
 * "Relighting"): the shade kernel's parameters. bands = 0: no relighting. 48 bytes.
 * The light buffer the kernel reads with them: entries [0, 16) hold the SH projection of
 * every dome's radiance, L_j = integral of L(w) Y_j(w) over the sphere (rgb; used when
 * cosine = 1); entries [16, 16 + table_w table_h B^2) the mapped dome's
 * G_j(n) = integral of L(w) Y_j(w) max(0, n . w) at table_w x table_h normals, lat-long like
 * the dome's map (row r at theta = pi (r + 1/2) / table_h, column c at phi = 2 pi (c + 1/2) /
 * table_w), B^2 entries per normal (used when cosine = 0; table_w = 0 without a map). */
typedef struct ts_relight_params {
    ts_u32 bands;   /* B of the file, 0..4 */
    ts_u32 cosine;  /* 1: the file's coefficients project V max(0, N . w) (bake --cosine) */
    ts_u32 table_w; /* the G table's normals, 0 when no dome has a map */
    ts_u32 table_h;
    float uniform[4];   /* rgb: the uniform domes' radiance, summed (used when cosine = 0) */
    ts_u32 patch_count; /* entries of the patch table (2 words each) */
    ts_u32 pad[3];
} ts_relight_params;
/* Entries of the light buffer before the G table. */
#define TS_RELIGHT_TABLE_FIRST 16u

/* Or'ed into the `sampling` argument of lib/lights.h (TS_SAMPLING_* in the low bits): domes
 * take no part, neither light-sampled nor found by escaping rays, at a vertex whose
 * environment light comes from the baked occlusion instead (shade.cl, --occlusion). */
#define TS_LIGHTS_NO_DOMES 0x100u
#define TS_SAMPLING_MODE(sampling) ((sampling)&0xffu)

/* Per-ray flags (ray field `flags`). */
#define TS_RAY_SHADOW 1u /* any hit below tmax ends the ray: it only answers "occluded?" */

#define TS_NO_HIT 3.402823466e+38f

/* Ray state as SoA: one buffer per field, generated from this one list (STYLE.md 7).
 * X(type, name, comment). */
/* clang-format off */
#define TS_RAY_FIELDS(X)                                                                    \
    X(ts_vec4, org, "origin xyz, w = how near hits on the patch the ray leaves are ignored")\
    X(ts_vec4, dir, "unit direction xyz, w = time in [0,1)")                                \
    X(ts_hit, hit, "closest hit so far; hit.t is the traversal tmax")                      \
    X(ts_u32, entry, "top-level resume state, TS_ENTRY_START or (node << 3 | pos)")         \
    X(ts_u32, pixel, "pixel index y * width + x")                                           \
    X(ts_u32, flags, "TS_RAY_SHADOW for shadow rays")                                       \
    X(ts_u32, from, "the patch the ray leaves + 1; 0 for eye rays")
/* clang-format on */

/* Path field `state`: bits 0-1 say which of the path's two ray slots it traced this wave
 * (the same bits shade writes to alive[] for the next wave), bits 2-3 how emission found by
 * its BSDF ray is weighted for MIS (kernels/shade.cl). */
#define TS_PATH_TRACED_BSDF 1u   /* ray slot i: the eye or BSDF ray */
#define TS_PATH_TRACED_SHADOW 2u /* ray slot wave_size + i: the shadow ray of a light sample */
#define TS_MIS_ONE 0u            /* weight 1: eye rays, --sampling bsdf, a scene without lights */
#define TS_MIS_BALANCE 1u        /* p_b / (p_b + p_light), the balance heuristic */
#define TS_MIS_ZERO 2u           /* --sampling light: light sampling alone counts emission */
#define TS_PATH_STATE(traced, mis_mode) ((traced) | ((mis_mode) << 2))
#define TS_PATH_MIS(state) (((state) >> 2) & 3u)
/* Bit 4: the path's BSDF ray leaves a vertex relit by the baked occlusion (--occlusion), so
 * the domes it finds were counted there already (shade.cl). */
#define TS_PATH_RELIT 16u
/* Bit 5: the path is inside glass: its last transmission through a TS_MAT_GLASS surface went
 * in (each transmission flips it; eye rays start outside). */
#define TS_PATH_INSIDE 32u

/* Path state as SoA, one entry per path of the wave (path i traces ray i), generated from
 * this list like the ray fields. X(type, name, comment). */
/* clang-format off */
#define TS_PATH_FIELDS(X)                                                                   \
    X(ts_vec4, throughput, "rgb: the path's weight up to its last vertex")                 \
    X(float, mis, "solid-angle pdf p_b of the BSDF sample that made the path's ray (1 for " \
                  "the eye ray), for the MIS weight of the emission that ray finds")        \
    X(ts_u32, state, "TS_PATH_STATE(TS_PATH_TRACED_* bits, TS_MIS_* mode of that weight)") \
    X(ts_vec4, pending, "rgb: the light sample's contribution, added if its shadow ray is "  \
                        "unoccluded")
/* clang-format on */

/* Every (struct, field) whose offset the host and the device must agree on; the struct's
 * size is checked with it. host/base/layout_check.c asserts the sizes at compile time;
 * kernels/layout.cl writes sizeof/offsetof of each entry back for tests/test_layout.c. */
/* clang-format off */
#define TS_LAYOUT_FIELDS(X)                                                                 \
    X(ts_vec4, w) X(ts_box, hi_z) X(ts_box4, hi_z) X(ts_tight4, hi_z) X(ts_qbvh_node, hi_z) X(ts_qbvh_node, child)             \
    X(ts_qbvh_node, parent) X(ts_qbvh_node, axes) X(ts_qbvh_node, parent_slot)               \
    X(ts_pair, window) X(ts_segment, lod) X(ts_segment, flags) X(ts_segment, shape) X(ts_hit, patch)               \
    X(ts_hit, prim) X(ts_patch_attr, flags) X(ts_patch_attr, xform) X(ts_xform, r2) X(ts_camera_params, forward)                     \
    X(ts_camera_params, width) X(ts_camera_params, seed) X(ts_camera_params, ray_count) X(ts_camera_params, projection) X(ts_camera_params, band) X(ts_camera_params, forward1) X(ts_camera_params, full_height) X(ts_camera_params, focal)      \
    X(ts_shade_params, spp) X(ts_shade_params, band) X(ts_light, dir) X(ts_light, radiance) X(ts_light, weight) X(ts_emitter, area) \
    X(ts_light, flags) X(ts_light, pos) X(ts_light, cos_inner) X(ts_light, falloff_min)             \
    X(ts_patch_attr, kd) X(ts_patch_attr, le_r) X(ts_patch_attr, color_tex)                    \
    X(ts_patch_attr, disp_offset) X(ts_patch_attr, st) X(ts_texture, kind)                    \
    X(ts_patch_attr, metallic) X(ts_patch_attr, clearcoat_gloss) X(ts_patch_attr, trim_count)      \
    X(ts_texture, level_page) X(ts_bake_params, orthographic) X(ts_bake_params, eye)          \
    X(ts_relight_params, uniform) X(ts_relight_params, patch_count) X(ts_relight_params, pad)     \
    X(ts_udiv, mul) X(ts_udiv, d) X(ts_order_divs, band) X(ts_order_divs, width)            \
    X(ts_order_divs, mask) X(ts_order_divs, npix) X(ts_order_divs, pad)
/* clang-format on */

#endif
