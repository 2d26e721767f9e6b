/* sky.c — the sun's position, Preetham's clear sky and the sun's disc, baked into a lat-long
 * map (sky.h has the sources and the units). */
#include "scene/sky.h"

#include <math.h>
#include <stddef.h>

#define DEG (M_PI / 180.0)

/* ---- solar position (NOAA's solar calculator, after Meeus) ------------------------------ */

static int leap_year(int y)
{
    return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
}

/* The Julian day at 0h UTC of a Gregorian date (Meeus, Astronomical Algorithms, ch. 7). */
static double julian_day(int y, int m, int d)
{
    if (m <= 2) y -= 1, m += 12;
    double a = floor(y / 100.0), b = 2.0 - a + floor(a / 4.0);
    return floor(365.25 * (y + 4716)) + floor(30.6001 * (m + 1)) + d + b - 1524.5;
}

int sky_solar_position(int year, int month, int day, double hour, double zone, double latitude,
                       double longitude, double *elevation_deg, double *azimuth_deg)
{
    static const int days[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
    if (month < 1 || month > 12) return -1;
    int length = days[month - 1] + (month == 2 && leap_year(year));
    if (day < 1 || day > length) return -1;
    /* Julian centuries since J2000.0 at the UTC instant. */
    double jd = julian_day(year, month, day) + (hour - zone) / 24.0;
    double t = (jd - 2451545.0) / 36525.0;
    double l0 = fmod(280.46646 + t * (36000.76983 + 0.0003032 * t), 360.0); /* mean longitude */
    double m = 357.52911 + t * (35999.05029 - 0.0001537 * t);               /* mean anomaly */
    double e = 0.016708634 - t * (0.000042037 + 0.0000001267 * t);          /* eccentricity */
    double c = sin(m * DEG) * (1.914602 - t * (0.004817 + 0.000014 * t)) +
               sin(2 * m * DEG) * (0.019993 - 0.000101 * t) + sin(3 * m * DEG) * 0.000289;
    double omega = 125.04 - 1934.136 * t;
    double lambda = l0 + c - 0.00569 - 0.00478 * sin(omega * DEG); /* apparent longitude */
    double eps0 =
        23.0 + (26.0 + (21.448 - t * (46.815 + t * (0.00059 - t * 0.001813))) / 60.0) / 60.0;
    double eps = (eps0 + 0.00256 * cos(omega * DEG)) * DEG; /* obliquity, corrected */
    double decl = asin(sin(eps) * sin(lambda * DEG));
    double y = tan(eps / 2) * tan(eps / 2);
    double eqtime = 4.0 / DEG *
                    (y * sin(2 * l0 * DEG) - 2 * e * sin(m * DEG) +
                     4 * e * y * sin(m * DEG) * cos(2 * l0 * DEG) -
                     0.5 * y * y * sin(4 * l0 * DEG) - 1.25 * e * e * sin(2 * m * DEG)); /* min */
    /* True solar time (minutes) and the hour angle (0 at solar noon, > 0 after). */
    double tst = hour * 60.0 + eqtime + 4.0 * longitude - 60.0 * zone;
    double ha = (tst / 4.0 - 180.0) * DEG, lat = latitude * DEG;
    double east = -cos(decl) * sin(ha);
    double north = cos(lat) * sin(decl) - sin(lat) * cos(decl) * cos(ha);
    double up = sin(lat) * sin(decl) + cos(lat) * cos(decl) * cos(ha);
    *elevation_deg = asin(fmax(-1.0, fmin(1.0, up))) / DEG;
    double az = atan2(east, north) / DEG;
    *azimuth_deg = az < 0.0 ? az + 360.0 : az;
    return 0;
}

void sky_direction(double elevation_deg, double azimuth_deg, double d[3])
{
    double e = elevation_deg * DEG, a = azimuth_deg * DEG;
    d[0] = cos(e) * sin(a), d[1] = cos(e) * cos(a), d[2] = sin(e);
}

/* ---- Preetham, Shirley and Smits 1999 ---------------------------------------------------- */

double sky_zenith_luminance(double t, double theta_s)
{
    double chi = (4.0 / 9.0 - t / 120.0) * (M_PI - 2.0 * theta_s);
    return 1000.0 * ((4.0453 * t - 4.9710) * tan(chi) - 0.2155 * t + 2.4192); /* kcd -> cd */
}

void sky_zenith_chromaticity(double t, double theta_s, double xy[2])
{
    /* [T^2 T 1] M [theta^3 theta^2 theta 1]^T, M of the paper's appendix A.2. */
    static const double mx[3][4] = {{0.00166, -0.00375, 0.00209, 0.0},
                                    {-0.02903, 0.06377, -0.03202, 0.00394},
                                    {0.11693, -0.21196, 0.06052, 0.25886}};
    static const double my[3][4] = {{0.00275, -0.00610, 0.00317, 0.0},
                                    {-0.04214, 0.08970, -0.04153, 0.00516},
                                    {0.15346, -0.26756, 0.06670, 0.26688}};
    double tv[3] = {t * t, t, 1.0},
           th[4] = {theta_s * theta_s * theta_s, theta_s * theta_s, theta_s, 1.0};
    xy[0] = xy[1] = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++)
            xy[0] += tv[i] * mx[i][j] * th[j], xy[1] += tv[i] * my[i][j] * th[j];
}

void sky_perez_coefficients(double t, double cy[5], double cx[5], double cyy[5])
{
    /* {slope, intercept} in T of A, B, C, D, E (appendix A.2). */
    static const double ky[5][2] = {{0.1787, -1.4630},
                                    {-0.3554, 0.4275},
                                    {-0.0227, 5.3251},
                                    {0.1206, -2.5771},
                                    {-0.0670, 0.3703}};
    static const double kx[5][2] = {{-0.0193, -0.2592},
                                    {-0.0665, 0.0008},
                                    {-0.0004, 0.2125},
                                    {-0.0641, -0.8989},
                                    {-0.0033, 0.0452}};
    static const double kyy[5][2] = {{-0.0167, -0.2608},
                                     {-0.0950, 0.0092},
                                     {-0.0079, 0.2102},
                                     {-0.0441, -1.6537},
                                     {-0.0109, 0.0529}};
    for (int i = 0; i < 5; i++) {
        cy[i] = ky[i][0] * t + ky[i][1];
        cx[i] = kx[i][0] * t + kx[i][1];
        cyy[i] = kyy[i][0] * t + kyy[i][1];
    }
}

double sky_perez(const double c[5], double theta, double gamma)
{
    double ct = fmax(cos(theta), 1e-6), cg = cos(gamma); /* the horizon as its limit */
    return (1.0 + c[0] * exp(c[1] / ct)) * (1.0 + c[2] * exp(c[3] * gamma) + c[4] * cg * cg);
}

void sky_init(ts_sky *s, double t, const double sun[3])
{
    double len = sqrt(sun[0] * sun[0] + sun[1] * sun[1] + sun[2] * sun[2]), xy[2];
    s->turbidity = t;
    for (int k = 0; k < 3; k++)
        s->sun[k] = sun[k] / len;
    s->theta_s = acos(fmax(0.0, fmin(1.0, s->sun[2])));
    sky_perez_coefficients(t, s->cy, s->cx, s->cyy);
    sky_zenith_chromaticity(t, s->theta_s, xy);
    s->zenith_y = sky_zenith_luminance(t, s->theta_s);
    s->zenith_x = xy[0], s->zenith_yy = xy[1];
}

void sky_xyz(const ts_sky *s, const double d[3], double xyz[3])
{
    xyz[0] = xyz[1] = xyz[2] = 0.0;
    if (!(d[2] > 0.0)) return;
    double theta = acos(fmin(1.0, d[2]));
    double cg = d[0] * s->sun[0] + d[1] * s->sun[1] + d[2] * s->sun[2];
    double gamma = acos(fmax(-1.0, fmin(1.0, cg)));
    double y = s->zenith_y * sky_perez(s->cy, theta, gamma) / sky_perez(s->cy, 0.0, s->theta_s);
    double x = s->zenith_x * sky_perez(s->cx, theta, gamma) / sky_perez(s->cx, 0.0, s->theta_s);
    double yy = s->zenith_yy * sky_perez(s->cyy, theta, gamma) / sky_perez(s->cyy, 0.0, s->theta_s);
    if (!(y > 0.0 && yy > 0.0)) return;
    xyz[0] = x / yy * y, xyz[1] = y, xyz[2] = (1.0 - x - yy) / yy * y;
}

void sky_xyz_to_rgb(const double xyz[3], double rgb[3])
{
    rgb[0] = fmax(0.0, 3.2406 * xyz[0] - 1.5372 * xyz[1] - 0.4986 * xyz[2]);
    rgb[1] = fmax(0.0, -0.9689 * xyz[0] + 1.8758 * xyz[1] + 0.0415 * xyz[2]);
    rgb[2] = fmax(0.0, 0.0557 * xyz[0] - 0.2040 * xyz[1] + 1.0570 * xyz[2]);
}

/* A lobe of Wyman, Sloan and Shirley's fit of the CIE 1931 observer. */
static double cie_lobe(double l, double mu, double s1, double s2)
{
    double t = (l - mu) / (l < mu ? s1 : s2);
    return exp(-0.5 * t * t);
}

void sky_cie_xyz(double l, double xyz[3])
{
    xyz[0] = 1.056 * cie_lobe(l, 599.8, 37.9, 31.0) + 0.362 * cie_lobe(l, 442.0, 16.0, 26.7) -
             0.065 * cie_lobe(l, 501.1, 20.4, 26.2);
    xyz[1] = 0.821 * cie_lobe(l, 568.8, 46.9, 40.5) + 0.286 * cie_lobe(l, 530.9, 16.3, 31.1);
    xyz[2] = 1.217 * cie_lobe(l, 437.0, 11.8, 36.0) + 0.681 * cie_lobe(l, 459.0, 26.0, 13.8);
}

/* ---- the sun's disc ------------------------------------------------------------------------ */

void sky_sun_radiance(double t, double theta_s, double rgb[3], double *tau)
{
    /* Kasten's relative optical mass, as the paper's A.2 uses it (theta in degrees there). */
    double deg = fmin(theta_s / DEG, 93.0);
    double m = 1.0 / (cos(theta_s) + 0.15 * pow(93.885 - deg, -1.253));
    double beta = 0.04608 * t - 0.04586, alpha = 1.3;
    double xyz[3] = {0, 0, 0}, y0 = 0.0;
    for (double l = 380.0; l <= 780.0; l += 5.0) { /* nm */
        double um = l * 1e-3, s = l * 1e-9;
        double planck = 1.0 / (pow(s, 5) * expm1(1.4387769e-2 / (s * 5778.0)));
        double tr = exp(-0.008735 * pow(um, -4.08) * m); /* Rayleigh */
        double ta = exp(-beta * pow(um, -alpha) * m);    /* aerosols (Angstrom) */
        double c[3];
        sky_cie_xyz(l, c);
        for (int k = 0; k < 3; k++)
            xyz[k] += planck * tr * ta * c[k];
        y0 += planck * c[1];
    }
    /* The disc's luminance outside the atmosphere: the luminous solar constant over its
     * solid angle. */
    double half = 0.5 * SKY_SUN_DIAMETER_DEG * DEG;
    double l0 = SKY_SUN_ILLUMINANCE / (2.0 * M_PI * (1.0 - cos(half)));
    for (int k = 0; k < 3; k++)
        xyz[k] *= l0 / y0;
    if (tau) *tau = xyz[1] / l0;
    sky_xyz_to_rgb(xyz, rgb);
}

/* ---- the map ------------------------------------------------------------------------------- */

/* The tinted sky's irradiance on a horizontal plane of the light's space (midpoint rule on
 * 64 x 256 cells of the upper hemisphere in (theta, phi)), linear Rec. 709. */
static void sky_irradiance(const ts_sky *s, const double tint[3], double e[3])
{
    const int nt = 64, np = 256;
    e[0] = e[1] = e[2] = 0.0;
    for (int i = 0; i < nt; i++) {
        double th = (i + 0.5) * 0.5 * M_PI / nt;
        double w = cos(th) * sin(th) * (0.5 * M_PI / nt) * (2.0 * M_PI / np);
        for (int j = 0; j < np; j++) {
            double ph = (j + 0.5) * 2.0 * M_PI / np, xyz[3], rgb[3];
            double d[3] = {sin(th) * cos(ph), sin(th) * sin(ph), cos(th)};
            sky_xyz(s, d, xyz);
            sky_xyz_to_rgb(xyz, rgb);
            for (int k = 0; k < 3; k++)
                e[k] += w * tint[k] * rgb[k];
        }
    }
}

/* The inverse of a 3x3 (row-major); 0 when singular. */
static int inverse3(const double m[9], double inv[9])
{
    double c[9] = {m[4] * m[8] - m[5] * m[7], m[2] * m[7] - m[1] * m[8], m[1] * m[5] - m[2] * m[4],
                   m[5] * m[6] - m[3] * m[8], m[0] * m[8] - m[2] * m[6], m[2] * m[3] - m[0] * m[5],
                   m[3] * m[7] - m[4] * m[6], m[1] * m[6] - m[0] * m[7], m[0] * m[4] - m[1] * m[3]};
    double det = m[0] * c[0] + m[1] * c[3] + m[2] * c[6];
    if (!(fabs(det) > 0.0)) return 0;
    for (int k = 0; k < 9; k++)
        inv[k] = c[k] / det;
    return 1;
}

double sky_bake(const sky_bake_args *a, float *rgb)
{
    double inv[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, e[3], ground[3];
    inverse3(a->to_world, inv);
    sky_irradiance(a->sky, a->sky_tint, e);
    for (int k = 0; k < 3; k++) {
        e[k] += a->sun_rgb[k] * a->sun_solid_angle * fmax(0.0, a->sky->sun[2]);
        ground[k] = a->ground[k] * e[k] / M_PI;
    }
    for (int y = 0; y < SKY_MAP_HEIGHT; y++) {
        double th = (y + 0.5) * M_PI / SKY_MAP_HEIGHT;
        for (int x = 0; x < SKY_MAP_WIDTH; x++) {
            double ph = (x + 0.5) * 2.0 * M_PI / SKY_MAP_WIDTH, xyz[3], c[3];
            double w[3] = {sin(th) * cos(ph), sin(th) * sin(ph), cos(th)}, d[3];
            for (int r = 0; r < 3; r++) /* the world direction in the light's space */
                d[r] = inv[3 * r] * w[0] + inv[3 * r + 1] * w[1] + inv[3 * r + 2] * w[2];
            double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            for (int r = 0; r < 3; r++)
                d[r] /= len;
            sky_xyz(a->sky, d, xyz);
            sky_xyz_to_rgb(xyz, c);
            float *px = &rgb[((size_t)y * SKY_MAP_WIDTH + x) * 3];
            for (int k = 0; k < 3; k++)
                px[k] = (float)(d[2] > 0.0 ? a->sky_tint[k] * c[k] : ground[k]);
        }
    }
    return 0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2];
}
