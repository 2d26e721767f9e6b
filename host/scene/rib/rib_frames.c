/* rib_frames.c — FrameBegin/FrameEnd (RI Spec 3.2 §4.1.1) and the checks on a file as a whole
 * scene. An animation writes one FrameBegin n ... FrameEnd block per frame, each with its own
 * options, camera and world; Tessera renders one of them (`tessera render --frame n`, by
 * default the first) and reads the requests of the others only as tokens: they are never
 * dispatched. Requests before the first FrameBegin (shared options) are read; everything
 * after the chosen frame's FrameEnd is skipped. At the end of a file that must make a scene
 * (rib_load), a file without a world block or geometry is an error (issue 15 item 3: such files
 * used to render a black image over the output), and one without light gets a headlight at the
 * camera, with a warning. */
#include "scene/rib/rib_internal.h"

#include "base/mat4.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

int rib_frames_skip(const rib_parser *p)
{
    const rib_frame_choice *f = &p->frames;
    if (strcmp(p->req, "FrameBegin") == 0 || strcmp(p->req, "FrameEnd") == 0) return 0;
    return f->done || (f->open && !f->reading);
}

/* What the frame being read starts from (rib_frame_start), at its FrameBegin. */
static void rib_frame_save(rib_parser *p)
{
    rib_frame_start *st = &p->frames.start;
    rib_state_save(p, &st->attrs);
    st->camera = p->scene->camera;
    st->patch_count = p->scene->patch_count;
    st->light_count = p->scene->light_count;
    st->dome = p->scene->dome.present;
}

/* Back to the start of the frame being read, which is then skipped like a frame not chosen.
 * Only while the frame has added nothing to the scene and stands before its world block with
 * no block open: returns 0 (and changes nothing) otherwise. */
static int rib_frame_leave(rib_parser *p)
{
    rib_frame_choice *f = &p->frames;
    const rib_frame_start *st = &f->start;
    const ts_scene *s = p->scene;
    if (p->phase != RIB_BEFORE_WORLD || p->depth > 0 || p->motion.active ||
        s->patch_count != st->patch_count || s->light_count != st->light_count ||
        s->dome.present != st->dome)
        return 0;
    rib_state_restore(p, &st->attrs, 1);
    p->scene->camera = st->camera;
    f->reading = 0;
    f->depth_skipped++;
    return 1;
}

/* The warning for frame f->number left as a depth-map pass. */
static void rib_frame_warn_depth(rib_parser *p, const char *type, const char *mode)
{
    char shown[2][RIB_PRINT_MAX], what[RIB_WARN_KEY];
    snprintf(what, sizeof what,
             "frame %d renders a depth map (Display \"%s\" \"%s\"), a shadow-map pass Tessera "
             "does not need: the next frame is read (--frame %d reads it)",
             p->frames.number, rib_printable(type, shown[0]), rib_printable(mode, shown[1]),
             p->frames.number);
    rib_warn_once(p, p->req_line, p->req_col, what);
}

/* Display name type mode: an image Tessera does not write (it writes the -o file), so it is
 * ignored with a warning; but a frame read by default whose primary Display (a name without
 * "+") writes a depth map (type "shadow" or "zfile", or mode "z") is a shadow-map pass, which
 * a renderer that traces its shadows does not need: the frame is skipped and the next one
 * read. Files write such passes before the frame they render. A Display outside frames
 * (between them) is the option of the frames that follow. */
int rib_req_display(rib_parser *p)
{
    rib_warn_once(p, p->req_line, p->req_col, "Display is ignored");
    rib_frame_choice *f = &p->frames;
    if (p->nargs < 3) return TS_OK;
    for (size_t i = 0; i < 3; i++)
        if (p->args[i].kind != RIB_ARG_STRING) return TS_OK; /* not Tessera's to check */
    const char *name = rib_arg_str(p, &p->args[0], 0), *type = rib_arg_str(p, &p->args[1], 0),
               *mode = rib_arg_str(p, &p->args[2], 0);
    if (name[0] == '+') return TS_OK;
    int depth = strcmp(type, "shadow") == 0 || strcmp(type, "zfile") == 0 || strcmp(mode, "z") == 0;
    if (!f->open) {
        f->depth_between = depth;
        rib_printable(type, f->between_type);
        rib_printable(mode, f->between_mode);
        return TS_OK;
    }
    if (!f->reading || f->wanted >= 0 || f->keep_depth || !depth || !rib_frame_leave(p))
        return TS_OK;
    rib_frame_warn_depth(p, type, mode);
    return TS_OK;
}

/* FrameBegin n: n an integer. Frames may not nest, nor open inside another block. */
int rib_req_frame_begin(rib_parser *p)
{
    rib_frame_choice *f = &p->frames;
    double v;
    size_t i = 0;
    int rc = rib_numbers(p, &i, 1, &v);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    if (!(v == floor(v) && fabs(v) < 2147483648.0))
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "FrameBegin: the frame number must be an integer, got %g", v);
    if (f->open)
        return rib_error_at(p, p->req_line, p->req_col,
                            "FrameBegin inside the frame %d at %d:%d (missing FrameEnd)", f->number,
                            f->line, f->col);
    if (p->depth > 0 || p->motion.active) {
        int line = p->depth ? p->stack[p->depth - 1].line : p->motion.line;
        int col = p->depth ? p->stack[p->depth - 1].col : p->motion.col;
        return rib_error_at(p, p->req_line, p->req_col,
                            "FrameBegin inside the block opened at %d:%d (a frame holds its world "
                            "block, not the other way round)",
                            line, col);
    }
    if (!f->done && p->phase == RIB_AFTER_WORLD)
        return rib_error_at(p, p->req_line, p->req_col,
                            "FrameBegin after the world block at %d:%d, which no frame holds",
                            p->world_line, p->world_col);
    if (f->count < RIB_MAX_FRAMES_LISTED) f->numbers[f->count] = (int)v;
    f->count++;
    f->open = 1;
    f->line = p->req_line;
    f->col = p->req_col;
    f->number = (int)v;
    f->reading = !f->done && (f->wanted < 0 || f->wanted == f->number);
    if (f->reading) rib_frame_save(p);
    if (f->reading && f->wanted < 0 && !f->keep_depth && f->depth_between) {
        f->reading = 0; /* the Display before the frame writes a depth map */
        f->depth_skipped++;
        rib_frame_warn_depth(p, f->between_type, f->between_mode);
    }
    return TS_OK;
}

/* FrameEnd: the frame read must have closed its blocks; then the rest of the file is
 * skipped. */
int rib_req_frame_end(rib_parser *p)
{
    rib_frame_choice *f = &p->frames;
    int rc = rib_no_more(p, 0);
    if (rc != TS_OK) return rc;
    if (!f->open) return rib_error_at(p, p->req_line, p->req_col, "FrameEnd without FrameBegin");
    if (f->reading) {
        rc = rib_check_closed(p);
        if (rc != TS_OK) return rc;
        f->done = 1;
        f->reading = 0;
    }
    f->open = 0;
    return TS_OK;
}

/* "1, 2, 3" (the first RIB_MAX_FRAMES_LISTED, then "... (N frames)"). */
static void rib_frames_list(const rib_frame_choice *f, char *buf, size_t cap)
{
    size_t n = 0;
    int shown = f->count < RIB_MAX_FRAMES_LISTED ? f->count : RIB_MAX_FRAMES_LISTED;
    buf[0] = '\0';
    for (int k = 0; k < shown && n < cap; k++)
        n += (size_t)snprintf(buf + n, cap - n, "%s%d", k ? ", " : "", f->numbers[k]);
    if (f->count > shown && n < cap) snprintf(buf + n, cap - n, ", ... (%d frames)", f->count);
}

int rib_frames_finish(rib_parser *p)
{
    rib_frame_choice *f = &p->frames;
    if (f->open)
        return rib_error_at(p, f->line, f->col, "FrameBegin is never closed (missing FrameEnd)");
    if (f->wanted < 0 || f->done) return TS_OK;
    if (f->count == 0)
        return rib_error_at(p, p->lx.line, p->lx.col,
                            "no frame %d: the file has no FrameBegin (render it without --frame)",
                            f->wanted);
    char list[512];
    rib_frames_list(f, list, sizeof list);
    return rib_error_at(p, p->lx.line, p->lx.col, "no frame %d: the file's frames are %s",
                        f->wanted, list);
}

/* Whether anything in the scene gives light: a light, a dome, an emissive patch. */
static int rib_scene_has_light(const ts_scene *s)
{
    if (s->light_count > 0 || s->dome.present) return 1;
    for (uint32_t q = 0; q < s->patch_count; q++)
        if (s->attr[q].le_r > 0.0f || s->attr[q].le_g > 0.0f || s->attr[q].le_b > 0.0f) return 1;
    return 0;
}

/* A scene without light gets a headlight at the camera: a point light at the eye with no
 * distance falloff (a distant light along the view for an orthographic camera), of
 * irradiance pi on a surface facing it, so that a white matte surface facing the camera
 * reflects radiance 1 and one seen at the angle a reflects cos(a). RenderMan shows such
 * scenes through its default surface shader (defaultsurface: a facing ratio, no light
 * needed); the headlight is its path-traced counterpart (docs/rib.md). */
static int rib_add_headlight(rib_parser *p)
{
    ts_scene *s = p->scene;
    double c2w[16];
    if (!mat4_invert(s->camera.world_to_camera, c2w))
        return ts_error_set(p->err, TS_E_INTERNAL, "%s: the camera transform is singular",
                            p->lx.file);
    const double eye[3] = {0, 0, 0}, ahead[3] = {0, 0, 1};
    ts_scene_light l = {.intensity = M_PI, .color = {1, 1, 1}};
    if (!mat4_point(c2w, eye, l.from) || !mat4_point(c2w, ahead, l.to))
        return ts_error_set(p->err, TS_E_INTERNAL, "%s: the camera leaves the float range",
                            p->lx.file);
    if (s->camera.projection == TS_PROJECTION_ORTHOGRAPHIC) {
        l.kind = SCENE_LIGHT_DISTANT;
    } else {
        l.kind = SCENE_LIGHT_POINT;
        l.falloff = 0.0, l.falloff_dist = 1.0, l.falloff_min = 0.0;
    }
    return scene_add_light(s, &l, p->err);
}

int rib_scene_check(rib_parser *p)
{
    const ts_scene *s = p->scene;
    const char *frame = p->frames.count ? " of the frame read" : "";
    if (s->patch_count == 0 && !p->world_seen) /* (a binary WorldBegin is at line 0) */
        return rib_error_at(p, p->lx.line, p->lx.col,
                            "the file ends without a world block%s (WorldBegin ... WorldEnd) and "
                            "holds no geometry: nothing to render",
                            frame);
    if (s->patch_count == 0)
        return rib_error_at(p, p->world_line, p->world_col,
                            "the world block%s holds no geometry: nothing to render", frame);
    if (rib_scene_has_light(s)) return TS_OK;
    rib_warn_once(p, p->world_line ? p->world_line : 1, p->world_col ? p->world_col : 1,
                  "the scene has no light Tessera renders (LightSource \"distantlight\", "
                  "\"pointlight\", \"spotlight\", \"ambientlight\" or \"domelight\", "
                  "AreaLightSource, Surface \"constant\"): it is lit by a headlight at the "
                  "camera, as RenderMan's default surface shows a scene without lights");
    return rib_add_headlight(p);
}
