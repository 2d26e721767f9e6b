/* rusticl_lanes_repro.c — a minimal reproducer of the Mesa 22.3 Rusticl (llvmpipe) bug that
 * made Tessera shade black there (issue 40): a bicubic Bézier patch's dP/du and dP/dv, each a
 * sum of the 16 control points (an array of 16-byte structs) read as float4 through a float
 * pointer (vload4) and weighted by scalars, the form of kernels/lib/bezier.h bezier_combine
 * under -DTS_CPU_LANES. Built with the control points' address a constant, the sums are right;
 * built with an address that depends on the work-item (cp + 16 * (u > 2), which is cp for every
 * item at run time), Mesa 22.3.6 gets a third of the components wrong (dP/dv's) while PoCL
 * gets them right. Tessera therefore builds its kernels without TS_CPU_LANES on Rusticl
 * (host/device/device.c dev_build_options). The "Treating load_kernel_arg in control flow as
 * uniform" warning Mesa prints for Tessera's kernels is not this bug: it comes with correct
 * images once the lanes are off.
 *
 * Build: cc -o rusticl_lanes_repro tools/rusticl_lanes_repro.c -lOpenCL
 * Run:   RUSTICL_ENABLE=llvmpipe ./rusticl_lanes_repro [PLATFORM]   (default "rusticl")
 * Prints both builds' outcome; exit status 0: both right, 1: one wrong (the bug), 77: no such
 * platform. Not part of the build: a report for Mesa and a check of a newer driver. */
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#include <stdio.h>
#include <string.h>

static const char *source =
    "typedef struct vec { float x, y, z, w; } vec;\n"
    "inline void basis(float t, float b[4]) {\n"
    "    float s = 1.0f - t, ts = 3.0f * (t * s);\n"
    "    b[0] = s * s * s; b[1] = ts * s; b[2] = ts * t; b[3] = t * t * t;\n"
    "}\n"
    "inline void basis_deriv(float t, float d[4]) {\n"
    "    float s = 1.0f - t;\n"
    "    d[0] = -3.0f * s * s; d[1] = 3.0f * (s * s - 2.0f * t * s);\n"
    "    d[2] = 3.0f * (2.0f * t * s - t * t); d[3] = 3.0f * t * t;\n"
    "}\n"
    "inline vec combine(__global const vec *cp, const float bu[4], const float bv[4]) {\n"
    "    __global const float *f = (__global const float *)cp;\n"
    "    float4 r[4];\n"
    "    for (int j = 0; j < 4; ++j)\n"
    "        r[j] = (bu[0] * vload4(4 * j, f) + bu[3] * vload4(4 * j + 3, f)) +\n"
    "               (bu[1] * vload4(4 * j + 1, f) + bu[2] * vload4(4 * j + 2, f));\n"
    "    float4 q = (bv[0] * r[0] + bv[3] * r[3]) + (bv[1] * r[1] + bv[2] * r[2]);\n"
    "    vec o = {q.x, q.y, q.z, 0.0f};\n"
    "    return o;\n"
    "}\n"
    "/* out[2i] = dP/du, out[2i + 1] = dP/dv at (uv[2i], uv[2i + 1]) */\n"
    "__kernel void derivs(__global const vec *cp, __global const float *uv,\n"
    "                     __global vec *out) {\n"
    "    uint i = get_global_id(0);\n"
    "    float u = uv[2 * i], v = uv[2 * i + 1];\n"
    "    __global const vec *f = cp + OFFSET;\n"
    "    float bu[4], bv[4], du[4], dv[4];\n"
    "    basis(u, bu); basis(v, bv); basis_deriv(u, du); basis_deriv(v, dv);\n"
    "    out[2 * i] = combine(f, du, bv);\n"
    "    out[2 * i + 1] = combine(f, bu, dv);\n"
    "}\n";

enum { N = 64 };

/* The kernel's sums in C, component by component. */
static void combine_ref(const float *f, const float bu[4], const float bv[4], float out[4])
{
    for (int c = 0; c < 4; ++c) {
        float r[4];
        for (int j = 0; j < 4; ++j)
            r[j] = (bu[0] * f[16 * j + c] + bu[3] * f[16 * j + 12 + c]) +
                   (bu[1] * f[16 * j + 4 + c] + bu[2] * f[16 * j + 8 + c]);
        out[c] = (bv[0] * r[0] + bv[3] * r[3]) + (bv[1] * r[1] + bv[2] * r[2]);
    }
}

static void basis_ref(float t, float b[4], float d[4])
{
    float s = 1.0f - t, ts = 3.0f * (t * s);
    b[0] = s * s * s, b[1] = ts * s, b[2] = ts * t, b[3] = t * t * t;
    d[0] = -3.0f * s * s, d[1] = 3.0f * (s * s - 2.0f * t * s);
    d[2] = 3.0f * (2.0f * t * s - t * t), d[3] = 3.0f * t * t;
}

int main(int argc, char **argv)
{
    const char *want = argc > 1 ? argv[1] : "rusticl";
    cl_platform_id ps[16], p = NULL;
    cl_uint np = 0;
    if (clGetPlatformIDs(16, ps, &np) != CL_SUCCESS) np = 0;
    for (cl_uint i = 0; i < np && !p; ++i) {
        char name[256] = "";
        clGetPlatformInfo(ps[i], CL_PLATFORM_NAME, sizeof name, name, NULL);
        if (strstr(name, want)) p = ps[i];
    }
    cl_device_id d;
    if (!p || clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 1, &d, NULL) != CL_SUCCESS) {
        printf(
            "rusticl_lanes_repro: no device on a platform named '%s' (RUSTICL_ENABLE=llvmpipe?)\n",
            want);
        return 77;
    }
    cl_int rc;
    cl_context ctx = clCreateContext(NULL, 1, &d, NULL, NULL, &rc);
    cl_command_queue q = clCreateCommandQueue(ctx, d, 0, &rc);
    /* scene/one_patch.rib's patch, x y z w a control point */
    static const float xyz[48] = {
        -1.5f, -1.5f, 0,      -0.5f, -1.5f, -0.25f, 0.5f, -1.5f, -0.25f, 1.5f, -1.5f, 0,
        -1.5f, -0.5f, -0.25f, -0.5f, -0.5f, -0.5f,  0.5f, -0.5f, -0.5f,  1.5f, -0.5f, -0.25f,
        -1.5f, 0.5f,  -0.25f, -0.5f, 0.5f,  -0.5f,  0.5f, 0.5f,  -0.5f,  1.5f, 0.5f,  -0.25f,
        -1.5f, 1.5f,  0,      -0.5f, 1.5f,  -0.25f, 0.5f, 1.5f,  -0.25f, 1.5f, 1.5f,  0};
    float cp[128] = {0}, uv[2 * N], out[8 * N];
    for (int i = 0; i < 16; ++i)
        for (int c = 0; c < 4; ++c)
            cp[4 * i + c] = c < 3 ? xyz[3 * i + c] : 1.0f;
    for (int i = 0; i < 2 * N; ++i)
        uv[i] = (float)((i * 37) % 101) / 100.0f;
    cl_mem dcp = clCreateBuffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof cp, cp, &rc);
    cl_mem duv = clCreateBuffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof uv, uv, &rc);
    cl_mem dout = clCreateBuffer(ctx, CL_MEM_WRITE_ONLY, sizeof out, NULL, &rc);
    int failed = 0;
    /* OFFSET: 0, or one that depends on the work-item (and is 0 for every item, u <= 1) */
    const char *options[2] = {"-cl-std=CL1.2 -DOFFSET=0u",
                              "-cl-std=CL1.2 -DOFFSET=16u*(uint)(u>2.0f)"};
    for (int varying = 0; varying < 2; ++varying) {
        cl_program prog = clCreateProgramWithSource(ctx, 1, &source, NULL, &rc);
        if (clBuildProgram(prog, 1, &d, options[varying], NULL, NULL) != CL_SUCCESS) {
            printf("rusticl_lanes_repro: the kernel does not build\n");
            return 1;
        }
        cl_kernel k = clCreateKernel(prog, "derivs", &rc);
        size_t global = N, local = 8;
        clSetKernelArg(k, 0, sizeof dcp, &dcp);
        clSetKernelArg(k, 1, sizeof duv, &duv);
        clSetKernelArg(k, 2, sizeof dout, &dout);
        if (clEnqueueNDRangeKernel(q, k, 1, NULL, &global, &local, 0, NULL, NULL) != CL_SUCCESS ||
            clEnqueueReadBuffer(q, dout, CL_TRUE, 0, sizeof out, out, 0, NULL, NULL) !=
                CL_SUCCESS) {
            printf("rusticl_lanes_repro: the launch fails\n");
            return 1;
        }
        int wrong = 0, first = -1;
        for (int i = 0; i < N; ++i) {
            float bu[4], bv[4], du[4], dv[4], ref[8];
            basis_ref(uv[2 * i], bu, du);
            basis_ref(uv[2 * i + 1], bv, dv);
            combine_ref(cp, du, bv, ref);
            combine_ref(cp, bu, dv, ref + 4);
            /* a few ulp of slack for the device's own rounding; the bug is far off */
            for (int c = 0; c < 8; ++c)
                if (c % 4 != 3 &&
                    !(out[8 * i + c] - ref[c] <= 1e-4f && ref[c] - out[8 * i + c] <= 1e-4f)) {
                    if (first < 0) first = 8 * i + c;
                    ++wrong;
                }
        }
        clReleaseKernel(k), clReleaseProgram(prog);
        printf("%s address: %s", varying ? "work-item dependent" : "constant",
               wrong ? "WRONG" : "right");
        if (wrong)
            printf(" (%d of %d components; first: item %d, %g instead of a value near the C sum)",
                   wrong, 6 * N, first / 8, out[first]);
        printf("\n");
        failed |= wrong != 0;
    }
    return failed;
}
