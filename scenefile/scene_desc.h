/* scene_desc: a parsed scene as plain data (camera, film, sampler, integrator, materials,
 * textures, lights, shapes, object instances), filled by pbrt_parser and read by the renderer.
 * Values keep the scene file's raw form (spectra as RGB / blackbody / named / sampled, the
 * glass given by name or coefficients) with pbrt-v4's defaults filled in, and each carries its
 * file:line:col so that the renderer can report what it cannot build precisely.
 *
 * Geometry stays in object space: every shape keeps its vertices as written plus its
 * object-to-world transform (the CTM at the Shape directive), and the renderer applies it.
 * Shapes between ObjectBegin/End go to object_shapes with the CTM of their definition; each
 * ObjectInstance places an object with its own transform: world = instance * shape * p.
 * Everything (strings, arrays, meshes) is owned by the scene_desc and freed with it.
 *
 * files lists every file the parse read (the main file, Include/Import files, PLY meshes and
 * imagemap PNGs), once each, in reading order, each with the path it was opened by and its
 * path relative to the main file's folder, so that a client can bundle a scene with
 * everything it needs and refuse files that lie outside that folder. */
#ifndef PRISMFARM_SCENE_DESC_H
#define PRISMFARM_SCENE_DESC_H

#include "err.h"
#include "params.h"
#include "pbrt_lexer.h"
#include "transform.h"
#include "vec3.h"
#include "warnings.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* Film defaults. "spectral" follows pbrt-v4 (16 buckets over 360-830 nm) so that a pbrt-v4
 * scene writes the channels pbrt-v4 would; "rgb" film uses prismfarm's own bucket grid
 * (docs/physics.md §1.2: 16 bins over 380-720 nm), which the rgb film also accepts as an
 * extension. */
#define SCENE_FILM_XRES_DEFAULT 1280
#define SCENE_FILM_YRES_DEFAULT 720
#define SCENE_SPECTRAL_NBUCKETS_DEFAULT 16
#define SCENE_SPECTRAL_LAMBDA_MIN_DEFAULT 360.0
#define SCENE_SPECTRAL_LAMBDA_MAX_DEFAULT 830.0
#define SCENE_RGB_NBUCKETS_DEFAULT 16
#define SCENE_RGB_LAMBDA_MIN_DEFAULT 380.0
#define SCENE_RGB_LAMBDA_MAX_DEFAULT 720.0

/* ---- spectra and texturable values ---- */

typedef enum scene_spectrum_kind {
    SCENE_SPECTRUM_CONSTANT,  /* "float x" v: the same value at every wavelength */
    SCENE_SPECTRUM_RGB,       /* "rgb x" [r g b], components >= 0; the renderer uplifts */
    SCENE_SPECTRUM_BLACKBODY, /* "blackbody x" T (kelvin, > 0), pbrt-v4's normalised Planck */
    SCENE_SPECTRUM_NAMED,     /* "spectrum x" "stdillum-D65" naming no file: the renderer resolves the name */
    SCENE_SPECTRUM_SAMPLED,   /* "spectrum x" [l0 v0 l1 v1 ...] or a spectrum file: lambda strictly increasing */
} scene_spectrum_kind_t;

typedef struct scene_spectrum {
    scene_spectrum_kind_t kind;
    double constant;    /* CONSTANT */
    double rgb[3];      /* RGB */
    double temperature; /* BLACKBODY */
    const char *name;   /* NAMED; SAMPLED read from a file: the name as written */
    const char *file;   /* SAMPLED read from a spectrum file: the path it was read by, else NULL */
    const char *searched; /* NAMED: the files looked for under that name ("\"a\" and \"b\"") */
    size_t count;       /* SAMPLED: number of (lambda, value) pairs, >= 1 */
    const double *lambda;
    const double *value;
    pbrt_loc_t loc; /* the parameter, or the directive when it is a default */
} scene_spectrum_t;

/* A float input of a material or texture: a constant, or a float texture. */
typedef struct scene_float_input {
    int texture; /* index into textures (of type float), or -1 */
    double value;
} scene_float_input_t;

/* A spectrum input: a constant spectrum, or a spectrum texture. */
typedef struct scene_spectrum_input {
    int texture; /* index into textures (of type spectrum), or -1 */
    scene_spectrum_t spectrum;
} scene_spectrum_input_t;

/* ---- textures ---- */

typedef enum scene_texture_type {
    SCENE_TEXTURE_FLOAT,
    SCENE_TEXTURE_SPECTRUM
} scene_texture_type_t;

typedef enum scene_texture_class {
    SCENE_TEX_CONSTANT,     /* "value"                  -> in1 */
    SCENE_TEX_CHECKERBOARD, /* "tex1" (1), "tex2" (0)   -> in1, in2 (2D only) */
    SCENE_TEX_IMAGEMAP,     /* "filename", ...          -> image */
    SCENE_TEX_SCALE,        /* "tex" (1) * "scale" (1)  -> in1 * amount */
    SCENE_TEX_MIX,          /* lerp("amount" (0.5), "tex1" (0), "tex2" (1)) -> in1, in2, amount */
    SCENE_TEX_BILERP,       /* "v00" (0), "v01" (1), "v10" (0), "v11" (1) -> in1..in4 */
    SCENE_TEX_DOTS,         /* "inside" (1), "outside" (0) -> in1, in2 */
    SCENE_TEX_FBM,          /* float: "octaves" (8), "roughness" (0.5) -> noise */
    SCENE_TEX_WRINKLED,     /* float: "octaves" (8), "roughness" (0.5) -> noise */
    SCENE_TEX_WINDY,        /* float: no parameters */
    SCENE_TEX_MARBLE,       /* spectrum: "octaves" (8), "roughness" (0.5), "scale" (1),
                             * "variation" (0.2) -> noise */
    SCENE_TEX_DIRECTIONMIX, /* "tex1" (0), "tex2" (1), "vector3 dir" (0 1 0) -> in1, in2, dir */
} scene_texture_class_t;

typedef struct scene_texture {
    const char *name;
    scene_texture_type_t type;
    scene_texture_class_t cls;
    pbrt_loc_t loc;
    transform_t to_world; /* the CTM at the Texture directive */
    /* "uv" mapping: (u, v) -> (su * u + du, sv * v + dv). The other 2D mappings (mapping 1
     * spherical, 2 cylindrical, 3 planar: v1, v2 and udelta, vdelta) leave su = sv = 1 and
     * du = dv = 0 to the texture and keep their own parameters in map. */
    double uscale, vscale, udelta, vdelta;
    struct {
        int kind; /* 0: uv */
        double v1[3], v2[3], ds, dt;
    } map;
    /* Inputs: float_in* when type is FLOAT, spec_in* when type is SPECTRUM. */
    scene_float_input_t float_in1, float_in2;
    scene_spectrum_input_t spec_in1, spec_in2;
    scene_float_input_t amount; /* MIX amount, SCALE scale */
    scene_float_input_t float_in3, float_in4; /* BILERP's v10, v11 */
    scene_spectrum_input_t spec_in3, spec_in4;
    int dimension; /* CHECKERBOARD: 2 (uv) or 3 (the texture-space point) */
    double dir[3]; /* DIRECTIONMIX, in texture space (to_world takes it to world) */
    struct {
        int octaves;
        double roughness, scale, variation;
    } noise;
    struct {
        const char *filename; /* resolved against the folder of the file that names it */
        const char *wrap;     /* "repeat" (default), "black", "clamp", "octahedralsphere" */
        const char *filter;   /* "bilinear" (default), "point", "trilinear", "ewa" */
        const char *encoding; /* "sRGB" (default), "linear" or "gamma G" */
        double scale;         /* 1 */
        bool invert;          /* false */
    } image;
} scene_texture_t;

/* ---- materials ---- */

/* What the parser made of a material's parameter while the scene was parsed, by one rule keyed
 * on the parameter's declared type and name that knows no material (pbrt_materials.c): a
 * "spectrum" given by a string (a spectrum file, read, confined and listed for the bundle, or a
 * name the loader resolves), or a file named by a "string" parameter ("filename",
 * "normalmap": confined, charged and listed, path the path to open). */
typedef struct scene_material_resolved {
    const char *param;         /* the parameter's name */
    const char *path;          /* a file parameter's path to open; NULL for a spectrum */
    scene_spectrum_t spectrum; /* a spectrum parameter's value */
} scene_material_resolved_t;

/* A material as the scene wrote it (pbrt-v4's Material and MakeNamedMaterial): its type and
 * its parameters unread. The loader finds the type's class and refuses an unknown one at
 * type_loc (scene/material_kind.h, the registry); the class reads the parameters when the scene
 * loads (scene/material_<name>.c, through scene/material_params.h), as pbrt-v4's
 * Material::Create reads the ParameterDictionary that outlives its parse. The description
 * knows no material: neither the list of types nor their fields. */
typedef struct scene_material {
    const char *type;    /* as written ("diffuse", "none", ...), in the description's memory */
    pbrt_loc_t type_loc; /* where the type was written (line 0: the default material) */
    const char *name; /* MakeNamedMaterial name, or NULL for Material */
    pbrt_loc_t loc;
    /* The directive's parameters (the description owns them; NULL for the default material):
     * the loader marks what the class reads and refuses the rest (params_check_unused). */
    params_t *params;
    /* The textures defined before the material: the ones its "texture" parameters may name
     * (a Texture must come before its use). */
    size_t ntextures;
    scene_material_resolved_t *resolved; /* in the description's memory */
    size_t nresolved;
} scene_material_t;

/* ---- lights ---- */

typedef enum scene_light_type {
    SCENE_LIGHT_POINT,    /* I, scale, from */
    SCENE_LIGHT_SPOT,     /* I, scale, from, to, coneangle (30), conedeltaangle (5) */
    SCENE_LIGHT_DISTANT,  /* L, scale, from (0,0,0), to (0,0,1): light travels from -> to */
    SCENE_LIGHT_INFINITE, /* L (uniform) or filename (an image), scale, illuminance */
    SCENE_LIGHT_GONIOMETRIC, /* I, scale, power, filename (a square equal-area image) */
    SCENE_LIGHT_PROJECTION,  /* scale, power, fov (90), filename (the image projected) */
} scene_light_type_t;

typedef struct scene_light {
    scene_light_type_t type;
    pbrt_loc_t loc;
    transform_t to_world;             /* the CTM at the LightSource directive */
    scene_spectrum_t spectrum;        /* I or L; default the colour space illuminant stdillum-D65 */
    double scale;                     /* 1 */
    /* pbrt-v4's "power" (point, spot, goniometric, projection: the emitted power) or
     * "illuminance" (distant: at normal
     * incidence; infinite: on a surface facing the whole sky); -1 when not given. */
    double power;
    vec3_t from, to;                  /* in light space: apply to_world */
    double coneangle, conedeltaangle; /* degrees */
    double fov;                       /* projection: degrees, the image's shorter axis */
    /* infinite, goniometric, projection: the image's path as opened (the checked real path in
     * a confined parse), or NULL for a uniform infinite light; filename_loc is where
     * "filename" was written. */
    const char *filename;
    pbrt_loc_t filename_loc;
    /* prismfarm extension (docs/physics.md §14.2): "float polarization", the degree of linear
     * polarisation of the emitted light (0, unpolarised), and "float polarizationangle", the
     * angle of its plane in degrees from the CTM's x axis toward its y axis. */
    double polarization, polarization_angle;
} scene_light_t;

typedef enum scene_area_light_type {
    SCENE_AREA_DIFFUSE,    /* L, scale, twosided */
    SCENE_AREA_COLLIMATED, /* extension: L, scale; emits only along the shape's normal */
} scene_area_light_type_t;

typedef struct scene_area_light {
    scene_area_light_type_t type;
    pbrt_loc_t loc;
    scene_spectrum_t L; /* default stdillum-D65 */
    double scale;       /* 1 */
    double power;       /* pbrt-v4's "power": the emitted power; -1 when not given */
    bool twosided;      /* false */
    /* diffuse: "string filename", an image of the radiance over the shape's (u, v) (pbrt-v4
     * DiffuseAreaLight with an image), as opened (the checked real path in a confined parse);
     * NULL without one. filename_loc is where it was written. */
    const char *filename;
    pbrt_loc_t filename_loc;
    /* As scene_light_t's, the angle from the shape's object-space x axis toward its y. */
    double polarization, polarization_angle;
} scene_area_light_t;

/* ---- shapes ---- */

typedef enum scene_shape_type {
    SCENE_SHAPE_SPHERE, /* radius (1) at the object-space origin */
    SCENE_SHAPE_DISK,   /* radius (1) at z = height (0), normal +z */
    SCENE_SHAPE_MESH,   /* triangles: trianglemesh, plymesh, bilinearmesh, loopsubdiv, cylinder
                         * or a cut sphere, made into triangles by the parser */
    SCENE_SHAPE_CURVE,  /* pbrt-v4 "curve": cubic Bezier segments (curve_*) */
} scene_shape_type_t;

/* Shapes that name the same PLY file may share one mesh's arrays (the scene owns them once). */
typedef struct scene_mesh {
    size_t nvertices;
    const double *P;  /* 3 per vertex */
    const double *N;  /* 3 per vertex, or NULL */
    const double *uv; /* 2 per vertex, or NULL */
    size_t ntriangles;
    const uint32_t *indices; /* 3 per triangle, each < nvertices */
} scene_mesh_t;

typedef struct scene_shape {
    scene_shape_type_t type;
    const char *kind; /* as written: "sphere", "disk", "cylinder", "trianglemesh", "plymesh",
                       * "bilinearmesh", "loopsubdiv", "curve" */
    pbrt_loc_t loc;
    transform_t to_world;     /* object to world (or to instance space inside an object) */
    bool reverse_orientation; /* ReverseOrientation was in effect */
    bool swaps_handedness;    /* to_world flips handedness */
    /* Flip the geometric normal: reverse_orientation XOR swaps_handedness (pbrt-v4). An
     * instanced shape is oriented as if its transform were composed with the instance's
     * (geometry.h, geometry_add_instance). */
    bool flip_normals;
    int material;   /* index into materials */
    int area_light; /* index into area_lights, or -1 */
    double radius;  /* SPHERE, DISK */
    double height;  /* DISK */
    /* pbrt-v4 "alpha" (1), when has_alpha: a float or float texture; where it is 0 rays
     * pass the surface, where it is in (0, 1) they pass with probability 1 - alpha. */
    bool has_alpha;
    scene_float_input_t alpha;
    scene_mesh_t mesh;
    /* CURVE: curve_segments cubic Bezier segments in object space (pbrt-v4 converts its
     * "bspline" and degree-2 curves to these), 4 control points (xyz) each in curve_cp, the
     * full width at each segment's ends in curve_width (2 each), and whether the type is
     * "cylinder" (else "flat"). A "ribbon" has curve_normals: each segment's two end normals
     * (unit, 6 numbers per segment; pbrt-v4 slerps between them along the segment). */
    size_t curve_segments;
    const double *curve_cp;
    const double *curve_width;
    const double *curve_normals;
    bool curve_cylinder;
    /* pbrt-v4's MediumInterface in effect at the shape: indices into media, -1 for none
     * (vacuum). A shape whose two differ is a boundary between media (pbrt-v4
     * IsMediumTransition); rays through any other shape keep the medium they are in. */
    int inside_medium, outside_medium;
} scene_shape_t;

typedef struct scene_object {
    const char *name;
    pbrt_loc_t loc;
    size_t first_shape; /* into object_shapes */
    size_t nshapes;
} scene_object_t;

typedef struct scene_instance {
    int object;
    pbrt_loc_t loc;
    transform_t to_world; /* the CTM at ObjectInstance: instance space to world */
    bool swaps_handedness;
} scene_instance_t;

/* ---- participating media ---- */

typedef enum scene_medium_type {
    SCENE_MEDIUM_HOMOGENEOUS, /* "homogeneous" */
    SCENE_MEDIUM_GRID,        /* "uniformgrid": a density grid */
    SCENE_MEDIUM_IGNORED,     /* "rgbgrid", "cloud": warned, rendered as vacuum */
    SCENE_MEDIUM_NANOVDB,     /* "nanovdb": density (and temperature) grids from a file */
} scene_medium_type_t;

/* MakeNamedMedium (pbrt-v4 media.cpp): the parameters as pbrt-v4 reads them, defaults filled
 * in ("preset" already resolved into sigma_a and sigma_s). */
typedef struct scene_medium {
    const char *name;
    const char *type_name; /* as written */
    scene_medium_type_t type;
    pbrt_loc_t loc;
    transform_t to_world; /* the CTM at MakeNamedMedium: medium space to world */
    scene_spectrum_t sigma_a, sigma_s; /* default constant 1 */
    double scale;                      /* 1 */
    double g;                          /* 0 */
    bool has_Le;
    scene_spectrum_t Le; /* emission (an illuminant), when has_Le */
    double Le_scale;     /* "Lescale", 1 */
    /* SCENE_MEDIUM_GRID: nx x ny x nz densities (x fastest) over the box [p0, p1] */
    int nx, ny, nz;
    const double *density;
    vec3_t p0, p1;
    /* SCENE_MEDIUM_NANOVDB (pbrt-v4 NanoVDBMedium::Create): the .nvdb file (a path to open,
     * as for any data file), the grids' names ("density", "temperature"), and the
     * temperature's offset ("temperatureoffset", defaulting to "temperaturecutoff", 0) and
     * scale (1); Le_scale is its "Lescale" */
    const char *filename;
    pbrt_loc_t filename_loc;
    const char *gridname, *temperaturename;
    double temperature_offset, temperature_scale;
} scene_medium_t;

/* ---- files read ---- */

typedef enum scene_file_kind {
    SCENE_FILE_MAIN,    /* the scene file given to pbrt_parse_file */
    SCENE_FILE_INCLUDE, /* named by Include or Import */
    SCENE_FILE_PLY,     /* Shape "plymesh" "string filename" */
    SCENE_FILE_IMAGE,   /* Texture "imagemap" or LightSource "infinite" "string filename" */
    SCENE_FILE_SPECTRUM, /* "spectrum x" "file.spd": a pbrt-v4 spectrum file */
    SCENE_FILE_LENS,     /* Camera "realistic" "string lensfile" */
    SCENE_FILE_BSDF,     /* Material "measured" "string filename": an RGL .bsdf file */
    SCENE_FILE_VOLUME,   /* MakeNamedMedium "nanovdb" "string filename": a .nvdb file */
} scene_file_kind_t;

typedef struct scene_file {
    scene_file_kind_t kind;
    /* The path the file was opened by: the name resolved against the folder of the file that
     * names it (or, failing that, the main file's folder, as pbrt-v4 does). */
    const char *path;
    /* The same file relative to the main file's folder, normalised lexically ("." and ".."
     * resolved, symbolic links not followed): "inc/shapes.pbrt", "../meshes/a.ply". For a
     * name written as an absolute path, the normalised absolute path. */
    const char *relative;
    /* The file is not inside the main file's folder tree (relative starts with "..") or was
     * named by an absolute path: a bundle of the main folder cannot carry it, and a bundler
     * should refuse the scene, naming `loc`. */
    bool outside;
    pbrt_loc_t loc; /* where it was first named; line 0 of the main file for the main file */
} scene_file_t;

/* ---- options ---- */

typedef struct scene_camera {
    const char *type;     /* "perspective", "orthographic", "spherical" or "realistic" */
    pbrt_loc_t loc;       /* the directive; line 0 of the main file when it is absent */
    double fov;           /* degrees, of the shorter image axis (pbrt-v4); default 90 */
    double lensradius;    /* 0: pinhole */
    double focaldistance; /* 1e6 */
    /* "float screenwindow" [x0 x1 y0 y1] (all 0: pbrt-v4's default from the aspect ratio) and
     * "float frameaspectratio" (0: the film's) */
    double screenwindow[4];
    double frameaspectratio;
    bool equirect; /* spherical: "string mapping" "equirectangular" (else "equalarea") */
    /* realistic: the lens file's text (NUL-terminated) and the path it was read from,
     * "float aperturediameter" (mm, 1), "float focusdistance" (m, 10), and prismfarm's
     * "string glasses" (one glass name per lens-file line; NULL when not given). */
    char *lens_text;
    size_t lens_len;
    const char *lens_path;
    pbrt_loc_t lens_loc, glasses_loc;
    double aperturediameter, focusdistance;
    const char **glasses;
    int nglasses;
    /* The CTM at the Camera directive (pbrt: camera-from-world); m_inv is world-from-camera.
     * The camera looks down +z in camera space, +y up, +x to the image's right. */
    transform_t camera_from_world;
    /* The medium the camera is in (pbrt-v4: the outside medium of the MediumInterface in
     * effect at Camera), an index into media, or -1 (vacuum). */
    int medium;
    /* prismfarm's camera analyser, any camera: "float analyzer" [degrees], an ideal linear
     * polariser in front of the lens with its axis at that angle from the image's right toward
     * its up (has_analyzer: given). */
    bool has_analyzer;
    double analyzer;
} scene_camera_t;

typedef enum scene_film_type { SCENE_FILM_RGB, SCENE_FILM_SPECTRAL } scene_film_type_t;

typedef struct scene_film {
    scene_film_type_t type;
    pbrt_loc_t loc;
    int xres, yres;
    const char *filename; /* as written ("pbrt.exr" by default) */
    int nbuckets;
    double lambda_min, lambda_max; /* nm */
    /* pbrt-v4's PixelSensor: the image is scaled by exposuretime * iso / 100; the sensor's
     * name ("cie1931" by default) and white balance temperature in K (0: pbrt-v4's default,
     * none for cie1931, 6500 for a camera), with where each was given. */
    double iso, exposuretime;
    const char *sensor;
    double whitebalance;
    pbrt_loc_t sensor_loc, whitebalance_loc;
    double maxcomponentvalue; /* per-sample clamp of the sensor's largest component; INFINITY */
    double diagonal;          /* mm, the film's diagonal (the realistic camera's film size) */
    /* The part of the image rendered (pbrt-v4): cropwindow [x0 x1 y0 y1] in [0, 1] (has_crop),
     * or pixelbounds [x0 x1 y0 y1] in pixels (has_pixelbounds); the cropwindow wins. */
    bool has_crop, has_pixelbounds;
    double cropwindow[4];
    int pixelbounds[4];
    pbrt_loc_t crop_loc; /* the parameter that set the bounds */
    /* prismfarm's "bool stokes" (false): the EXR carries S1-S3 layers beside S0 and a degree-
     * and angle-of-polarisation preview is written (docs/rendering.md, "Polarisation"). */
    bool stokes;
} scene_film_t;

/* PixelFilter (pbrt-v4's filters; gaussian when the file has none). */
typedef struct scene_filter {
    const char *type; /* "box", "gaussian", "mitchell", "sinc", "triangle" */
    pbrt_loc_t loc;
    double xradius, yradius, sigma, b, c, tau;
} scene_filter_t;

typedef struct scene_sampler {
    const char *type; /* pbrt's sampler name as written (sampling/sampler.h reads it) */
    pbrt_loc_t loc;
    int pixelsamples; /* 16; "stratified" gives xsamples * ysamples */
    int seed;         /* 0 */
} scene_sampler_t;

typedef struct scene_integrator {
    const char *type; /* "simplepath", "path", "whitted", "photon" or "auto" (the default) */
    pbrt_loc_t loc;
    /* The raw parameters, unchecked: the renderer looks up what it knows and then calls
     * params_check_unused() to reject the rest. Never NULL. */
    params_t *params;
} scene_integrator_t;

typedef struct scene_desc {
    scene_camera_t camera;
    scene_film_t film;
    scene_filter_t filter;
    scene_sampler_t sampler;
    scene_integrator_t integrator;

    scene_material_t *materials; /* materials[0] is pbrt-v4's default diffuse 0.5 */
    size_t nmaterials;
    scene_texture_t *textures;
    size_t ntextures;
    scene_light_t *lights;
    size_t nlights;
    scene_area_light_t *area_lights;
    size_t narea_lights;
    scene_shape_t *shapes; /* world shapes */
    size_t nshapes;
    scene_object_t *objects;
    size_t nobjects;
    scene_shape_t *object_shapes;
    size_t nobject_shapes;
    scene_instance_t *instances;
    size_t ninstances;
    scene_file_t *files; /* every file read, once each (see the top of this header) */
    size_t nfiles;
    /* What the scene asks for that is accepted without being simulated (never NULL). */
    warnings_t *warnings;
    /* MakeNamedMedium directives, in file order, and the first one's place. */
    scene_medium_t *media;
    size_t nmedia;
    pbrt_loc_t media_loc;

    /* private: capacities and owned allocations */
    size_t cap_materials, cap_textures, cap_lights, cap_area_lights, cap_shapes, cap_objects,
        cap_object_shapes, cap_instances, cap_files, cap_media;
    void **owned;
    size_t nowned, cap_owned;
} scene_desc_t;

/* An empty scene with pbrt-v4's defaults (perspective camera at the origin, rgb film, the
 * default diffuse material, "auto" integrator). */
scene_desc_t *scene_desc_new(err_t *err);
void scene_desc_destroy(scene_desc_t **self_p);

/* Memory owned by the scene, freed by scene_desc_destroy. */
void *scene_desc_alloc(scene_desc_t *self, size_t size, err_t *err);
const char *scene_desc_strdup(scene_desc_t *self, const char *s, err_t *err);
/* Hands a malloc'ed block to the scene (freed with it; freed at once on failure). */
int scene_desc_adopt(scene_desc_t *self, void *ptr, err_t *err);

/* Append a zeroed element and return its index (or -1 on out-of-memory). */
int scene_desc_add_material(scene_desc_t *self, err_t *err);
int scene_desc_add_texture(scene_desc_t *self, err_t *err);
int scene_desc_add_light(scene_desc_t *self, err_t *err);
int scene_desc_add_area_light(scene_desc_t *self, err_t *err);
int scene_desc_add_shape(scene_desc_t *self, bool in_object, err_t *err);
int scene_desc_add_object(scene_desc_t *self, err_t *err);
int scene_desc_add_instance(scene_desc_t *self, err_t *err);
int scene_desc_add_file(scene_desc_t *self, err_t *err);
/* A shape's media start as -1 (none). */
int scene_desc_add_medium(scene_desc_t *self, err_t *err);

/* Lookups by name (linear; -1 when absent). */
int scene_desc_find_texture(const scene_desc_t *self, const char *name, scene_texture_type_t type);
int scene_desc_find_material(const scene_desc_t *self, const char *name);
int scene_desc_find_object(const scene_desc_t *self, const char *name);
int scene_desc_find_medium(const scene_desc_t *self, const char *name);
/* The entry whose relative path is relative (compared as strings), or -1. */
int scene_desc_find_file(const scene_desc_t *self, const char *relative);

/* Totals over world shapes and instanced objects, for reports and tests. */
size_t scene_desc_triangle_count(const scene_desc_t *self);

#endif
