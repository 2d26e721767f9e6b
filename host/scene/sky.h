/* sky.h — daylight for PxrEnvDayLight (docs/rib.md "Daylight"), in plain C:
 * - the sun's position from a date, a time and a place: the equations of NOAA's Solar
 *   Calculator (NOAA Global Monitoring Laboratory), which are Meeus's ("Astronomical
 *   Algorithms", 1991, ch. 7, 22, 24, 25, 28: the sun's apparent longitude, the obliquity,
 *   the declination and the equation of time in Julian centuries since J2000.0); no
 *   atmospheric refraction (the sun's centre, as a vacuum would show it);
 * - the clear sky of Preetham, Shirley and Smits 1999, "A Practical Analytic Model for
 *   Daylight" (SIGGRAPH 99): Perez et al.'s distribution of luminance and of the chromaticities
 *   x, y (the paper's eq. 3, coefficients of its appendix A.2, linear in the turbidity T),
 *   scaled by the zenith luminance (eq. 4 after A.2) and zenith chromaticities (A.2's
 *   matrices). Hosek and Wilkie 2012 would need its fitted data tables, which we do not
 *   carry; RenderMan documents PxrEnvDayLight as Preetham's sky;
 * - the sun's disc: its radiance outside the atmosphere (a black body of 5778 K whose
 *   luminance gives SKY_SUN_ILLUMINANCE over the disc of SKY_SUN_DIAMETER_DEG) times the
 *   paper's appendix A.2 transmittances of Rayleigh scattering and of the aerosols (Angstrom's
 *   formula with beta = 0.04608 T - 0.04586, alpha = 1.3) along the relative optical mass of
 *   Kasten's formula; ozone, mixed gases and water vapour (tabulated in the paper) are left
 *   out, and the disc is uniform (no limb darkening).
 * Luminances are in cd/m^2 (the paper's Y is in kcd/m^2); colours are linear Rec. 709 whose
 * luminance (0.2126 R + 0.7152 G + 0.0722 B) is that luminance. Directions are unit vectors
 * in a frame whose +z is the zenith; for the solar position +x is east and +y north.
 * tests/test_sky.c checks the numbers. */
#ifndef TS_SKY_H
#define TS_SKY_H

/* The baked sky map (sky_bake): a lat-long image of SKY_MAP_WIDTH x SKY_MAP_HEIGHT texels,
 * about 0.7 degrees each; the circumsolar brightening of Preetham's sky is a few degrees
 * wide, and the sun's disc is not in the map (a distant light draws it). */
#define SKY_MAP_WIDTH 512
#define SKY_MAP_HEIGHT 256
/* The sun's angular diameter at sunSize 1 (RenderMan's documented 0.55 degrees). */
#define SKY_SUN_DIAMETER_DEG 0.55
/* The sun's illuminance at normal incidence outside the atmosphere, lux (the luminous solar
 * constant, 128 klx as the IES uses it). */
#define SKY_SUN_ILLUMINANCE 128000.0
/* PxrEnvDayLight's haziness is the turbidity T; Preetham's fit holds for T in [1.7, 10]
 * (RenderMan: "the lower limit of the model is 1.7 ... 10 is the upper limit"). */
#define SKY_TURBIDITY_MIN 1.7
#define SKY_TURBIDITY_MAX 10.0

/* The sun's elevation above the horizon and azimuth (clockwise from north), degrees, at
 * `hour` hours after midnight local standard time (fractional) on year-month-day of the
 * Gregorian calendar, in time zone `zone` hours east of UTC, at latitude (north > 0) and
 * longitude (east > 0) in degrees. Returns 0, or -1 when the month or day does not exist
 * (month 1..12, day 1..its length). Accuracy: about 0.01 degree (Meeus's figure for these
 * series, for years near 2000), without refraction. */
int sky_solar_position(int year, int month, int day, double hour, double zone, double latitude,
                       double longitude, double *elevation_deg, double *azimuth_deg);
/* The unit direction towards (elevation, azimuth), degrees: x east, y north, z up. */
void sky_direction(double elevation_deg, double azimuth_deg, double d[3]);

/* Preetham's zenith luminance Y_z, cd/m^2, for turbidity t and the sun at zenith angle
 * theta_s (radians, 0..pi/2). */
double sky_zenith_luminance(double t, double theta_s);
/* Preetham's zenith chromaticity (x, y) for turbidity t and sun zenith angle theta_s. */
void sky_zenith_chromaticity(double t, double theta_s, double xy[2]);
/* The Perez coefficients A..E of the luminance Y and the chromaticities x and y for
 * turbidity t (Preetham's appendix A.2). */
void sky_perez_coefficients(double t, double cy[5], double cx[5], double cyy[5]);
/* Perez et al.'s F(theta, gamma) = (1 + A e^(B / cos theta)) (1 + C e^(D gamma) + E cos^2
 * gamma) for coefficients c = {A, B, C, D, E}, theta the view's zenith angle (< pi/2),
 * gamma its angle to the sun (radians). */
double sky_perez(const double c[5], double theta, double gamma);

/* A clear sky of turbidity t with the sun towards `sun` (unit, z up, sun[2] >= 0). */
typedef struct ts_sky {
    double turbidity, sun[3], theta_s;
    double zenith_y, zenith_x, zenith_yy; /* Y_z (cd/m^2), x_z, y_z */
    double cy[5], cx[5], cyy[5];          /* Perez coefficients of Y, x, y */
} ts_sky;

void sky_init(ts_sky *s, double t, const double sun[3]);
/* The sky's radiance towards unit direction d as CIE XYZ, Y in cd/m^2: Y = Y_z F(theta,
 * gamma) / F(0, theta_s), likewise x and y; 0 below the horizon (d[2] <= 0). */
void sky_xyz(const ts_sky *s, const double d[3], double xyz[3]);
/* CIE XYZ -> linear Rec. 709 (D65), negative channels (out of gamut) clipped to 0. */
void sky_xyz_to_rgb(const double xyz[3], double rgb[3]);
/* The CIE 1931 2-degree observer at wavelength nm (Wyman, Sloan and Shirley's multi-lobe
 * fit, JCGT 2(2), 2013). */
void sky_cie_xyz(double nm, double xyz[3]);

/* The radiance of the sun's disc seen through a sky of turbidity t with the sun at zenith
 * angle theta_s (< pi/2), linear Rec. 709 whose luminance is in cd/m^2. Its luminous
 * transmittance (the ratio to the disc's luminance outside the atmosphere) in *tau when tau
 * is not NULL. */
void sky_sun_radiance(double t, double theta_s, double rgb[3], double *tau);

/* What sky_bake draws. to_world maps the light's space (where sky.sun is, z its zenith) to
 * the world, a row-major 3x3 acting on column vectors (rotation and scale; directions are
 * renormalised); the map is in Tessera's orientation (row 0 looks along world +z, column u
 * at azimuth atan2(y, x) = 2 pi u, lib/lights.h env_lookup). */
typedef struct sky_bake_args {
    const ts_sky *sky;
    double to_world[9];
    double sky_tint[3];     /* times the sky's radiance */
    double sun_rgb[3];      /* the sun disc's radiance (with its tint), for the ground */
    double sun_solid_angle; /* sr; 0 with no sun */
    double ground[3];       /* the ground's albedo below the horizon (0: black) */
} sky_bake_args;

/* Bakes the map: rgb[(y * SKY_MAP_WIDTH + x) * 3 + c] is the radiance at the centre of texel
 * (x, y): above the light's horizon sky_tint times the sky, below it a Lambertian ground of
 * albedo `ground` lit by the sun and the tinted sky, ground / pi times their irradiance on
 * a horizontal plane (unshadowed). Returns that irradiance's luminance (lux). */
double sky_bake(const sky_bake_args *a, float *rgb);

#endif
