/* scene: a scene ready to render -- shapes in Embree, materials, textures, lights, camera,
 * film and integrator settings -- as the render kernels read it. scene_new gives an empty
 * scene that a loader (scene_load.c, from a parsed pbrt file) or a test fills through the
 * scene_add_* functions, then scene_finish builds the acceleration structure and light
 * distribution. Objects hold shapes once and instances place them (Embree instances), so
 * instancing costs no copies. scene_surface resolves any hit, instanced or not, to its shape,
 * material, light, texture coordinates and world-space geometric and shading normals.
 * After scene_finish the scene is immutable and safe to share between threads: scene_retain
 * gives another holder (a thread, a cache, a photon phase) a reference, and scene_destroy
 * drops one, freeing the scene with the last. */
#ifndef PRISMFARM_SCENE_H
#define PRISMFARM_SCENE_H

#include "alias.h"
#include "bssrdf.h"
#include "crystal.h"
#include "dispersion.h"
#include "envmap.h"
#include "err.h"
#include "filter.h"
#include "geometry.h"
#include "integrators.h"
#include "lens.h"
#include "light_bvh.h"
#include "material_kind.h"
#include "measured.h"
#include "medium.h"
#include "projmap.h"
#include "sampler.h"
#include "sensor.h"
#include "spectral_grid.h"
#include "spectrum.h"
#include "texture.h"
#include "transform.h"
#include "vec3.h"
#include "warnings.h"

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

/* The numbers of a material; textures are NULL where the material has no such input (a
 * NULL roughness is 0). The models themselves are bsdf/'s (pbrt-v4's BxDFs). */
typedef struct material {
    material_kind_t kind; /* never MATERIAL_UNIAXIAL or MATERIAL_SUBSURFACE (material_kind.h) */
    /* How outputs name it: its MakeNamedMaterial name (named = 1), else where the file made it,
     * "jewel.pbrt:57" (the file's base name and line), else "(unnamed)" (built in code). */
    char name[64];
    int named;
    /* The numbers only one class reads, in its own record (scene/material_<name>.h, e.g.
     * material_sheet_t): data points at a record of class data_kind's (its kind, or
     * MATERIAL_UNIAXIAL or MATERIAL_SUBSURFACE for a dielectric they loaded as), owned by the
     * scene (scene_add_material copies it, scene_destroy frees it); NULL: none. Read it only
     * through the class header's accessor (material_sheet_of(m), ...), which checks data_kind
     * and gives NULL for another class's material. */
    material_kind_t data_kind;
    const void *data;
    /* diffuse albedo, coated diffuse base, diffuse transmission reflectance; a conductor's
     * reflectance when eta is NULL */
    const texture_t *reflectance;
    /* conductor's (or coated conductor's base) complex index (both or neither) */
    const spectrum_t *eta, *k;
    /* dielectric, thin dielectric, and the coatings' interface */
    ior_model_t ior;
    int dispersive; /* the index varies over the film's range */
    /* Roughness (NULL: 0) of the conductor, dielectric or coating interface (a coated
     * conductor's base keeps its own: material_coatedconductor.h); remapped by pbrt-v4's
     * RoughnessToAlpha when remaproughness. */
    const texture_t *uroughness, *vroughness;
    int remaproughness;
    /* A conductor or dielectric whose constant roughness pbrt-v4 calls effectively smooth
     * (smooth: the delta code everywhere) or not (rough: nowhere); neither when a texture
     * decides per hit. Set by the loader; a material without roughness is smooth anyway. */
    int smooth, rough;
    /* Shading-normal perturbation (pbrt-v4 BumpMap, NormalMap; render/shading.h
     * shading_perturb): a float displacement texture, or a tangent-space normal map
     * (texture_new_normalmap), which wins when both are given, as in pbrt-v4. NULL: none. */
    const texture_t *displacement, *normalmap;
    /* A thin-film coating on a smooth dielectric or conductor (bsdf/delta.h, docs/physics.md
     * §13): its thickness in nm (0, the default: no coating) and its index. Not read from
     * scene files yet (the parser's parameters are still to be added). */
    double film_thickness;
    ior_model_t film_ior;
    /* The material needs polarised transport even in a scene without sheets, analyser or
     * polarised lights (a coherent crystal's interference colours: render/crystal_coherent.h);
     * scene_finish turns it on. */
    int needs_polarisation;
} material_t;

typedef enum light_kind {
    LIGHT_AREA,       /* "diffuse" area light on a shape: radiance L, cosine emission */
    LIGHT_COLLIMATED, /* prismfarm's "collimated" area light: emits only along the normal */
    LIGHT_POINT,      /* intensity I from a point */
    LIGHT_SPOT,       /* point light limited to a cone with a smooth falloff */
    LIGHT_DISTANT,    /* the sun: parallel light of irradiance L along dir */
    LIGHT_INFINITE,   /* environment: uniform radiance L, or an image (envmap) */
    LIGHT_GONIOMETRIC, /* point light whose intensity over directions is an image (gonio) */
    LIGHT_PROJECTION,  /* point light projecting an image through a frustum (projmap) */
} light_kind_t;

typedef struct light {
    light_kind_t kind;
    /* Emission spectrum with pbrt-v4's normalisation already applied: the spectrum divided
     * by its photometric value and multiplied by "scale", so scale sets the brightness
     * (luminance Y) and the spectrum the colour. */
    const spectrum_t *spectrum;
    double scale;     /* the multiplier to apply to spectrum_eval(spectrum, lambda) */
    int shape;        /* area and collimated lights: index of the emitting shape */
    int twosided;     /* area lights: emit from both sides */
    /* Diffuse area light with an image (pbrt-v4 DiffuseAreaLight "filename"; NULL: none): its
     * radiance at a point of texture coordinates (u, v) is scale * spectrum(lambda) *
     * texture_eval(area_image, u, v, lambda), the spectrum the colour space's D65 normalised to
     * Y = 1 and the texture the image's RGB illuminant factors, bilinear, clamped at the edges,
     * v = 0 the image's bottom row (pbrt-v4 flips v as its image textures do). area_image_y is
     * the mean of the image's texel luminances (its power is that times pi A). */
    const texture_t *area_image;
    double area_image_y;
    vec3_t position;  /* point and spot */
    vec3_t direction; /* spot axis and distant light: the direction light travels (unit) */
    double cos_total_width, cos_falloff_start; /* spot */
    /* Infinite light with an image (NULL: uniform): its radiance along world direction w is
     * scale * spectrum(lambda) * envmap_texel_value(texel of to_light(w)), the spectrum being
     * the colour space's illuminant D65 normalised to Y = 1 (pbrt-v4 ImageInfiniteLight). The
     * scene owns it. to_light and from_light map directions between world and light space. */
    const envmap_t *envmap;
    /* Goniometric light at position (pbrt-v4 GoniometricLight): its intensity toward world
     * direction w is scale * spectrum(lambda) * envmap_texel_value(gonio, texel of
     * to_light(w)), the texels greys (the image's channel average) so that the value is that
     * average at every wavelength; to_light includes pbrt-v4's swap of y and z, so the image
     * centre points along the CTM's +y. Not an environment: render.c's envmap loops skip it. */
    const envmap_t *gonio;
    /* Projection light at position (pbrt-v4 ProjectionLight): intensity scale *
     * spectrum(lambda) * projmap_texel_value(texel of to_light(w)) inside the frustum, 0
     * outside; to_light includes pbrt-v4's flip of y. */
    const projmap_t *projmap;
    transform_t to_light, from_light;
    /* Partially linearly polarised emission (docs/physics.md §14.2; area, point, spot and
     * distant lights): the degree of polarisation in [0, 1] (0: unpolarised, the default) and
     * the unit world direction whose part perpendicular to a ray is the plane of polarisation
     * of the light along it (lights_stokes). */
    double polarisation;
    vec3_t polarisation_axis;
} light_t;

typedef enum shape_kind { SHAPE_MESH, SHAPE_SPHERE, SHAPE_DISK, SHAPE_CURVE } shape_kind_t;

typedef struct shape {
    shape_kind_t kind;
    int object;   /* -1 for a world shape, else the object (placed by instances) it belongs to */
    int material; /* index into materials */
    int light;    /* index into lights, or -1 (always -1 in objects) */
    int flip;     /* reverse orientation (ReverseOrientation XOR handedness swap) */
    transform_t to_world; /* spheres and disks: to world, or to the object's space */
    double radius, height;
    /* Meshes, in world space (or the object's space): positions xyz, 3 indices per triangle,
     * optional per-vertex normals (already flipped by ReverseOrientation, as pbrt-v4's
     * TriangleMesh does) and uvs (NULL when absent). */
    double *positions;
    uint32_t *indices;
    double *normals;
    double *uvs;
    size_t nverts, ntris;
    /* Curves (scene_add_curves): ntris cubic Bezier segments, 4 control points each in
     * positions (nverts = 4 ntris) with their radii, and whether pbrt-v4's "cylinder" shading
     * normal applies. */
    double *radii;
    int cylinder;
    /* Area sampling: total world-space area and, for meshes, a distribution over triangles
     * by area. */
    double area;
    alias_t *triangles;
    /* pbrt-v4 "alpha": NULL for an opaque shape, else a float texture; where it is a < 1 a
     * ray passes the surface with probability 1 - a (render/shading.h shading_alpha_pass). */
    const texture_t *alpha;
    /* pbrt-v4's MediumInterface: the media inside and outside (indices into scene_t.media,
     * -1 for vacuum). Where the two differ the shape is a boundary: a ray leaving it along w
     * is in outside when w . ng > 0, else in inside; any other shape leaves a ray in the
     * medium it was in (pbrt-v4 IsMediumTransition). */
    int medium_inside, medium_outside;
} shape_t;

/* An object placed in the world. */
typedef struct instance {
    int object;
    transform_t to_world; /* the object's space to world */
} instance_t;

/* What a ray hit, resolved (scene_surface). */
typedef struct surface {
    const shape_t *shape;
    const material_t *material;
    int light;   /* the shape's area light (index into lights), or -1 */
    vec3_t p;    /* world-space point */
    /* Unit geometric normal in world space, outward as the shape's orientation says. A mesh
     * with vertex normals turns it toward their side (pbrt-v4 Triangle: n = FaceForward(n, ns)),
     * so the vertex normals decide which side is outside. */
    vec3_t ng;
    /* Unit shading normal in world space, on ng's side: the interpolated vertex normal, or ng
     * when the mesh has none (or they interpolate to zero). */
    vec3_t ns;
    int smooth;  /* ns comes from vertex normals */
    double u, v; /* texture coordinates (pbrt-v4's defaults where a mesh has no uv) */
    /* World-space dp/du, not normalised (pbrt-v4's: a sphere's or disk's phi direction, a
     * triangle's from its uv): the direction of "uroughness". The zero vector where it is
     * undefined (a degenerate uv mapping, a sphere's pole). */
    vec3_t dpdu;
    /* World-space dp/dv, likewise (a triangle's from its uv; a sphere's theta direction, a
     * disk's radial one, with pbrt-v4's parameterisations' signs). */
    vec3_t dpdv;
} surface_t;

typedef enum camera_kind {
    CAMERA_PERSPECTIVE,  /* pbrt-v4's default */
    CAMERA_ORTHOGRAPHIC, /* parallel rays along +z from the screen window on the z = 0 plane */
    CAMERA_SPHERICAL,    /* every direction around the camera, mapped onto the image */
    CAMERA_REALISTIC,    /* rays traced from the film through a lens system (camera_t.lens) */
} camera_kind_t;

typedef struct camera {
    camera_kind_t kind;
    transform_t camera_to_world; /* pbrt camera space: looks down +z, +y up, +x right */
    double fov_deg;              /* perspective: angle of the shorter image axis */
    double lens_radius, focal_distance;
    /* Perspective and orthographic: pbrt-v4's screen window (x0, x1, y0, y1); all zero for
     * its default ([-aspect, aspect] x [-1, 1], or the transpose for portrait images), the
     * aspect being frame_aspect, or the film's when that is 0. */
    double screen[4];
    double frame_aspect;
    int equirect; /* spherical: equirectangular mapping (else pbrt-v4's default equal-area) */
    /* realistic: the lens (owned by the scene, scene_destroy frees it) and whether any of its
     * glasses disperse over the film's range (a camera ray then depends on wavelength). */
    lens_system_t *lens;
    int lens_dispersive;
    /* A camera analyser (docs/physics.md §14): an ideal linear polariser in front of the lens
     * whose transmission axis is at analyser_angle radians from the image's right toward its
     * up (k x right, k toward the camera). 0: none. */
    int analyser;
    double analyser_angle;
} camera_t;

/* Integrator "photon" (docs/rendering.md): a photon pass (render/photon.h) fills a caustic
 * store before the camera pass, which then gathers with `integrator` (path or Whitted). */
typedef enum photon_store_kind {
    PHOTON_STORE_PHOTONMAP, /* a kd-tree of photons, density estimation at gather time */
    PHOTON_STORE_LIGHTMAP,  /* per-surface texel grids (thesis ch. 6), read at gather time */
} photon_store_kind_t;

typedef struct photon_settings {
    int enabled;        /* the photon pass runs and the camera pass uses its store */
    photon_store_kind_t store;
    double lightmap_density; /* light-map texels per unit area (thesis: 400 to 1000) */
    int mindepth;       /* scattering events before a photon may be stored (thesis: minimum
                         * recursion depth); 1 = the caustic store's L S+ D */
    uint64_t photons;   /* photons emitted (before the energy rescale, N in Phi / N) */
    double radius;      /* gather radius in scene units; 0: automatic (photon_gather_radius) */
    int k;              /* > 0: the k nearest photons within radius; 0: every photon within it */
    int maxdepth;       /* scattering events a photon may undergo */
    double threshold;   /* Russian roulette below this fraction of the emitted power */
    int monochromerays; /* rays followed per photon at a dispersive interface (only 1 yet) */
} photon_settings_t;

/* How next-event estimation chooses among the emitters (pbrt-v4's "string lightsampler";
 * scene/emitters.h, docs/rendering.md "Choosing a light"). */
typedef enum light_sampler_kind {
    LIGHT_SAMPLER_BVH,     /* the light BVH, by importance as seen from the shading point */
    LIGHT_SAMPLER_POWER,   /* in proportion to each emitter's power, wherever the point */
    LIGHT_SAMPLER_UNIFORM, /* every emitter alike */
} light_sampler_kind_t;

/* How a camera path samples where it scatters in a medium (Integrator "string mediumsampling";
 * render/render.c medium_flight, docs/physics.md §12): free flight alone, or free flight
 * combined by MIS with equiangular sampling toward a light point (sampling/equiangular.h) for
 * the single-scattered light of point, spot and small area lights in homogeneous media. */
typedef enum medium_sampling_kind {
    MEDIUM_SAMPLING_FREEFLIGHT,
    MEDIUM_SAMPLING_EQUIANGULAR,
} medium_sampling_kind_t;

typedef struct render_settings {
    /* The camera pass's integrator; with photon.enabled it is the gather (path or Whitted). */
    integrator_kind_t integrator;
    dispersion_kind_t dispersion;
    int maxdepth;
    int spp;
    uint64_t seed;
    /* The camera samples' numbers (`Sampler "..."`; sampling/sampler.h). */
    sampler_kind_t sampler;
    int xres, yres;
    spectral_grid_t grid;
    int visible_sampling; /* hero: sample wavelengths by the visible pdf, not uniformly */
    /* Light the camera ray sees directly is evaluated at 16 wavelengths rather than the hero
     * tuple's 4 (render.c, direct_lanes); 1: at the hero tuple's alone, for tests that watch
     * how the sampler pairs wavelengths with positions through directly seen light. */
    int direct_hero_only;
    /* At a rough surface whose lanes' lobes differ (a rough dispersive dielectric), weight
     * the lanes by spectral MIS (render.c) rather than ending the secondary lanes as pbrt-v4
     * does ("bool spectralmis", default true). */
    int spectral_mis;
    /* Ray splitting at dense stones ("integer splitdepth", the path integrators; render.c,
     * split_here): at the first split_depth smooth-dielectric events of a camera path whose
     * choice is real (0 < R < 1) at a material of index n_d >= 1.9 (a dense stone), both the
     * reflected and the refracted branch are followed, each weighted by its Fresnel factor,
     * instead of one chosen at random. 0: never (every event chooses). */
    int split_depth;
    char filename[512];   /* output named by the scene's Film, may be empty */
    int film_spectral;    /* Film "spectral" (else "rgb") */
    photon_settings_t photon;
    /* The pixel filter (PixelFilter; render_tile samples each camera sample's offset from it
     * through scene_t.filter). render_settings_default: box of radius 0.5, the plain jitter. */
    filter_params_t filter;
    /* pbrt-v4's PixelSensor: every sample's sensor record (its XYZ for cie1931, a camera's
     * RGB: scene_t.sensor) is scaled by exposuretime * iso / 100, then scaled down so that its
     * largest component is at most max_component (pbrt-v4's maxcomponentvalue, applied to the
     * sensor's values before the filter weight), then taken to XYZ by the sensor's matrix. */
    double imaging_ratio;
    double max_component; /* INFINITY: no clamp */
    /* Film cropwindow / pixelbounds: xres x yres is the rendered (cropped) image, whose pixel
     * (0, 0) is pixel (crop_x0, crop_y0) of the full_xres x full_yres film: the camera and the
     * random numbers use the full film's coordinates, so a crop is bit-identical to the same
     * pixels of the full render. full_xres 0: no crop. */
    int full_xres, full_yres, crop_x0, crop_y0;
    /* The camera pass simulates the scene's participating media (pbrt-v4's volpath and the
     * integrators whose pbrt-v4 counterparts do; render/volume.h). 0: media are ignored, as
     * pbrt-v4's "path" ignores them. */
    int media;
    /* Where camera paths scatter in media (render_settings_default: equiangular+MIS). */
    medium_sampling_kind_t medium_sampling;
    /* How next-event estimation picks a light (LIGHT_SAMPLER_BVH, the zero value, by default);
     * the photon pass always emits by power. */
    light_sampler_kind_t light_sampler;
    /* pbrt-v4's "bool regularize" (path, volpath, bdpt): after a path's first non-specular
     * bounce its near-specular lobes are roughened (bsdf/regularize.h). The camera pass only,
     * and not with a photon store, whose caustics it would count twice. */
    int regularize;
    /* Camera paths carry a Stokes carrier per lane (polar/polar_frame.h, docs/physics.md §14):
     * Mueller matrices at smooth interfaces and sheets, diffuse and rough surfaces depolarise.
     * 0 (the default): intensities only, as before, not one bit different. scene_finish turns
     * it on where the scene calls for it (scene_t.polarising); a test may set it besides. */
    int polarised;
    /* The file asked for it (Integrator "bool polarized" true): the plan says so. */
    int polarised_asked;
    /* The job's setting `polarized` (scene/overrides.h: FILE, OFF, ON; a user's --polarized or
     * the plan's decision): OFF keeps polarisation off whatever the scene has (scene_finish). */
    int polarised_setting;
    /* Stokes output (Film "bool stokes"; needs polarised): the image's buckets are four planes
     * of grid.n, S0 (the spectral image as without it) then S1, S2, S3 in the image's frame
     * (x right, y up): render_settings_buckets. */
    int stokes;
    /* What the polarisation pilot measured and decided (render/polar_pilot.h
     * polar_pilot_record), for the plan's report; run 0: it did not run (a polariser, analyser
     * or Stokes output already asked for polarisation, no Fresnel interface, the caller did not
     * decide, or the job's setting came decided: a worker's scene). */
    struct {
        int run;
        int on;           /* the decision (polar_pilot_decide): polarisation carried */
        double change;    /* relative RMS change of pixel luminance, polarised against not */
        double change_hi; /* its bound two standard errors up: what the decision compares */
        double target;    /* the error it was compared with */
        double seconds_plain, seconds_polarised; /* the pilot's renders, wall clock */
        int forced; /* the user forced the setting (--polarized on|off): no pilot, no rule */
    } polar_pilot;
} render_settings_t;

typedef struct scene {
    geometry_t *geometry;
    shape_t *shapes; /* world and object shapes; hit_t.shape indexes this */
    size_t nshapes;
    size_t nobjects;
    instance_t *instances; /* hit_t.instance indexes this */
    size_t ninstances;
    material_t *materials;
    size_t nmaterials;
    light_t *lights;
    size_t nlights;
    alias_t *light_power; /* lights by power: "power" light sampling and photon emission */
    /* The emitters the light samplers choose among (scene/emitters.h): each triangle of an
     * area light's mesh is one, any other light is one. Light i's emitters are
     * light_emitter0[i] .. light_emitter0[i + 1] - 1 (nlights + 1 entries). */
    size_t *light_emitter0;
    size_t nemitters;
    light_bvh_t *light_bvh; /* over the emitters by index; distant and infinite ones left out */
    int *infinite_lights;   /* the distant and infinite lights, chosen beside the BVH */
    size_t ninfinite;
    texture_t **textures; /* owned */
    size_t ntextures;
    spectrum_t **spectra; /* owned */
    size_t nspectra;
    envmap_t **envmaps;   /* owned */
    size_t nenvmaps;
    projmap_t **projmaps; /* owned */
    size_t nprojmaps;
    measured_t **measured; /* owned; with the path each was read from (measured_paths) */
    char **measured_paths;
    size_t nmeasured;
    bssrdf_table_t **bssrdf; /* owned: the subsurface materials' tables (scene_own_bssrdf) */
    size_t nbssrdf;
    camera_t camera;
    filter_sampler_t *filter; /* settings.filter's sampler (owned); NULL: the box of radius 0.5 */
    /* The Film's sensor (owned); NULL: cie1931 without white balance, the film records XYZ. */
    sensor_t *sensor;
    render_settings_t settings;
    /* The integrator the file's Integrator directive or --integrator names ("auto" when
     * neither does), beside what settings say runs: outputs print both where they differ. */
    char integrator_asked[24];
    int has_dispersion;   /* any dispersive material: spectral fan-out is ever needed */
    int has_interface;    /* a shape with an "interface" material (shadow rays pass it) */
    /* Why polarisation is carried (render_settings_t.polarised; scene/plan.c reports it):
     * shapes with a polariser or retarder sheet, the camera's analyser, lights that emit
     * polarised light. */
    int polarising_sheets;
    int polarised_lights;
    int has_alpha;        /* some shape has an alpha: shadow rays test it (shading_occluded) */
    /* Participating media, owned; a NULL entry is a medium that is not simulated (vacuum).
     * camera_medium: the medium camera rays start in, -1 for vacuum. has_medium_boundary:
     * some shape separates two different media. */
    medium_t **media;
    size_t nmedia;
    int camera_medium;
    int has_medium_boundary;
    /* What the scene file asks for that is accepted without being simulated: the parser's
     * lines and the loader's (scene_load), for `render`, `plan` and the client to print.
     * Owned; NULL for a scene built in code. */
    warnings_t *warnings;
    vec3_t bounds_lo, bounds_hi;
    double scene_radius;  /* radius of a sphere around the bounds (distant light sampling) */
    /* Holders of the scene (scene_retain): 1 from scene_new. */
    atomic_int holders;
} scene_t;

scene_t *scene_new(err_t *err);
/* Another reference to a finished scene, for a holder that frees it with scene_destroy like
 * its own; returns self. Safe from any thread. */
scene_t *scene_retain(scene_t *self);
/* Drops the caller's reference and nulls *self_p; the last reference frees the scene. */
void scene_destroy(scene_t **self_p);

/* The scene owns what it is given from here on (also on failure). */
int scene_own_texture(scene_t *self, texture_t *tex, err_t *err);
int scene_own_spectrum(scene_t *self, spectrum_t *s, err_t *err);
int scene_own_envmap(scene_t *self, envmap_t *e, err_t *err);
/* Likewise for a projection light's image (freed on failure too). */
int scene_own_projmap(scene_t *self, projmap_t *m, err_t *err);
/* Likewise for a measured BSDF read from path (freed on failure too), which
 * scene_find_measured finds by that path (NULL: none yet). */
int scene_own_measured(scene_t *self, measured_t *m, const char *path, err_t *err);
const measured_t *scene_find_measured(const scene_t *self, const char *path);

/* Likewise for a subsurface material's BSSRDF table (destroyed on failure too). */
int scene_own_bssrdf(scene_t *self, bssrdf_table_t *t, err_t *err);
/* Appends a medium (owned from here on, also on failure; NULL: one that is not simulated) and
 * returns its index, or -1. */
int scene_add_medium(scene_t *self, medium_t *m, err_t *err);
/* The medium a ray is in after it leaves surface sf along w, having been in `current` (an
 * index into media or -1): shape_t's rule. */
int scene_medium_after(const surface_t *sf, vec3_t w, int current);

/* The material has an index of refraction (ior): glass, a thin slab, a coating's interface. */
int material_has_ior(material_kind_t kind);
/* The spectral buckets an image of these settings holds: grid.n, or 4 grid.n with the Stokes
 * planes (render_settings_t.stokes). */
int render_settings_buckets(const render_settings_t *rs);
/* A polariser or retarder sheet: crossed straight, a Mueller matrix with polarisation. */
int material_is_sheet(material_kind_t kind);

/* Returns the new material's index, or -1. The scene keeps its own copy of m->data (the
 * class's record, of material_class_of(m->data_kind)->data_size bytes). */
int scene_add_material(scene_t *self, const material_t *m, err_t *err);
/* Returns the new light's index, or -1. Area lights are attached by scene_add_* shape calls. */
int scene_add_light(scene_t *self, const light_t *l, err_t *err);
/* Shapes: each returns the new shape's index, or -1. area_light is a light index or -1; the
 * light's shape field is set here. Mesh arrays are copied. */
int scene_add_mesh(scene_t *self, const double *positions, size_t nverts, const uint32_t *indices,
                   size_t ntris, const double *normals, const double *uvs, int material,
                   int area_light, int flip, err_t *err);
int scene_add_sphere(scene_t *self, const transform_t *to_world, double radius, int material,
                     int area_light, int flip, err_t *err);
int scene_add_disk(scene_t *self, const transform_t *to_world, double radius, double height,
                   int material, int area_light, int flip, err_t *err);

/* Curves (pbrt-v4 "curve"; geometry.h geometry_object_add_curves): nseg cubic Bezier
 * segments, 4 control points (cp, 12 numbers per segment) with their radii (4 per segment), in
 * world space, or in an object's space when object >= 0 (no area lights). A hit's v is
 * pbrt-v4's, across the width; cylinder turns the shading normal as pbrt-v4's "cylinder"
 * type does; normals (6 per segment, or NULL) make the segments pbrt-v4's "ribbon", whose
 * normal flip reverses. Arrays are copied. */
int scene_add_curves(scene_t *self, int object, const double *cp, const double *radii,
                     const double *normals, size_t nseg, int cylinder, int flip, int material,
                     err_t *err);

/* Objects: scene_add_object returns a new object's index (or -1); the scene_add_object_*
 * functions add shapes in the object's own space (no area lights: pbrt-v4 has none in
 * instances either) until scene_add_instance first places the object with to_world (affine,
 * invertible). Each returns the new shape's or instance's index, or -1. */
int scene_add_object(scene_t *self, err_t *err);
int scene_add_object_mesh(scene_t *self, int object, const double *positions, size_t nverts,
                          const uint32_t *indices, size_t ntris, const double *normals,
                          const double *uvs, int material, int flip, err_t *err);
int scene_add_object_sphere(scene_t *self, int object, const transform_t *to_world, double radius,
                            int material, int flip, err_t *err);
int scene_add_object_disk(scene_t *self, int object, const transform_t *to_world, double radius,
                          double height, int material, int flip, err_t *err);
int scene_add_instance(scene_t *self, int object, const transform_t *to_world, err_t *err);

/* Resolves a hit from geometry_intersect on this scene. */
void scene_surface(const scene_t *self, const hit_t *h, surface_t *out);

/* A mesh's vertex normal interpolated at barycentrics (1 - b1 - b2, b1, b2) of triangle prim,
 * in the mesh's own space and not normalised; the zero vector when the mesh has no normals. */
vec3_t scene_mesh_normal(const shape_t *s, uint32_t prim, double b1, double b2);

/* Commits the geometry, sets has_dispersion from the materials over settings.grid and
 * validates their index models there, and builds the light distribution. */
int scene_finish(scene_t *self, err_t *err);

/* Emitted power of a light up to a factor common to all lights: its luminance (scale times
 * its spectrum's Y) times its geometric factor (pi A for a one-sided area light, 4 pi for a
 * point light, ...); used to pick lights in proportion to power. Finite and >= 0: 0 for a
 * zero-area or black light, capped at DBL_MAX / (nlights + 1) so that the powers sum. */
double scene_light_power(const scene_t *self, const light_t *l);

/* Fills light_emitter0, nemitters, infinite_lights and light_bvh from the finished lights and
 * shapes (scene_finish calls it; again replaces what it built); O(n log n) in the emitters.
 * Defined with the rest of the emitters' code in scene/emitters.c, which sits above this header. */
int scene_emitters_build(scene_t *self, err_t *err);

/* A light's luminance factor: scale times its spectrum's Y (scale alone without a spectrum);
 * scene_light_power is this times the light's geometric factor. */
double scene_light_luminance(const light_t *l);

/* Default settings: path tracer, hero dispersion, maxdepth 5, 16 spp, seed 1,
 * 1280x720 (pbrt-v4's default), the default spectral grid; no photon pass (its settings hold
 * the "photon" integrator's defaults: 1e6 photons, automatic radius, maxdepth 5, threshold
 * 0.01, one monochrome ray). */
render_settings_t render_settings_default(void);

#endif
