/* scene_pack.h — a loaded scene as one block of bytes and back, so that rank 0 of an MPI
 * render can broadcast the scene it loaded and the other ranks need none of its files
 * (docs/rendering.md "Several devices and processes"). The block is for processes of the
 * same build on machines of the same byte order: fixed-size structs are copied as they are. */
#ifndef TS_SCENE_PACK_H
#define TS_SCENE_PACK_H

#include "scene/scene.h"

#include <stddef.h>

/* Packs every array and field of s into one malloc'd block (*out, *size): the patches,
 * their attributes and normals, the transforms, the textures with every tile and their
 * source names, the camera and the lights (the dome's environment map by file name). */
int scene_pack(const ts_scene *s, void **out, size_t *size, ts_error *err);

/* The scene of a block scene_pack made, into a zeroed *s (scene_free frees it). A block
 * that is cut short, or not one of ours, is TS_E_USAGE and leaves *s zeroed. */
int scene_unpack(const void *block, size_t size, ts_scene *s, ts_error *err);

#endif
