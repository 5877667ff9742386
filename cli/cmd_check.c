/* prismfarm check: every refusal and every warning of a scene in one run, so that porting a
 * scene from pbrt-v4 takes one look instead of a run per construct. The parser goes on after
 * each refused directive (pbrt_parse_file_check); a scene that parses is then loaded, which
 * adds the loader's warnings or its refusal. */
#include "commands.h"

#include "cli_args.h"
#include "cli_json.h"
#include "pbrt_parser.h"
#include "scene_load.h"
#include "warnings.h"

#include <stdio.h>

static void usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm check SCENE.pbrt [--json]\n"
            "\n"
            "Reads SCENE and its included files and prints every directive and parameter\n"
            "prismfarm refuses (\"error\") and everything it accepts without simulating it\n"
            "(\"warning\"), each as file:line:col. When nothing is refused while parsing, the\n"
            "scene is also loaded, which checks what the loader checks (spectra, glass, textures,\n"
            "lights) and adds its own warnings.\n");
    cli_args_help(out, opts);
    fprintf(out, "\n"
                 "exit status: 0 the scene renders (warnings allowed), 1 something is refused,\n"
                 "2 bad command line\n");
}

static json_t *lines_json(const warnings_t *w)
{
    json_t *a = json_array();
    for (size_t i = 0; i < warnings_count(w); i++)
        json_array_append_new(a, cli_json_string(warnings_at(w, i)));
    return a;
}

int cmd_check(int argc, char **argv)
{
    int json = 0;
    const cli_opt_t opts[] = {
        CLI_OPT_JSON(.dst = &json, .help = "print JSON: {scene, renders, errors, warnings}"),
        CLI_OPT_HELP,
        {0},
    };
    int first;
    const cli_cmd_t cmd = {.name = "check", .opts = opts, .usage = usage};
    int parsed = cli_args_parse(&cmd, argc, argv, &first);
    if (parsed != CLI_ARGS_GO)
        return parsed;
    if (argc - first != 1) {
        fprintf(stderr, "prismfarm check: %s\n",
                first == argc ? "no scene given" : "one scene at a time");
        usage(stderr, opts);
        return 2;
    }
    const char *path = argv[first];
    err_t err = {{0}};
    warnings_t *errors = warnings_new(&err);
    warnings_t *warnings = warnings_new(&err);
    if (!errors || !warnings) {
        fprintf(stderr, "prismfarm check: %s\n", err.msg);
        warnings_destroy(&errors);
        warnings_destroy(&warnings);
        return 1;
    }
    scene_desc_t *desc = pbrt_parse_file_check(path, errors, &err);
    if (!desc)
        warnings_add_text(errors, err.msg);
    scene_t *scene = NULL;
    /* A scene with refusals may miss what was refused: loading it would report the holes.
     * Its materials' parameters, which their classes read when the scene loads, are read all
     * the same, so their refusals come in the same look. */
    if (desc && warnings_count(errors) > 0 && scene_load_check_materials(desc, errors, &err) != 0)
        warnings_add_text(errors, err.msg);
    if (desc && warnings_count(errors) == 0) {
        scene_overrides_t ov = {.seed = -1};
        scene = scene_load(desc, &ov, &err);
        if (!scene)
            warnings_add_text(errors, err.msg);
    }
    warnings_copy(warnings, scene ? scene->warnings : desc ? desc->warnings : NULL);
    int renders = warnings_count(errors) == 0;
    int rc = renders ? 0 : 1;
    if (json) {
        json_t *o = json_object();
        json_object_set_new(o, "scene", cli_json_string(path));
        json_object_set_new(o, "renders", json_boolean(renders));
        json_object_set_new(o, "errors", lines_json(errors));
        json_object_set_new(o, "warnings", lines_json(warnings));
        json_object_set_new(o, "warnings_dropped",
                            json_integer((json_int_t)warnings_dropped(warnings)));
        if (cli_json_print(o, JSON_INDENT(2)) != 0) {
            fprintf(stderr, "prismfarm check: cannot write JSON\n");
            rc = 1;
        }
    } else {
        for (size_t i = 0; i < warnings_count(errors); i++)
            printf("error: %s\n", warnings_at(errors, i));
        for (size_t i = 0; i < warnings_count(warnings); i++)
            printf("warning: %s\n", warnings_at(warnings, i));
        printf("%s: %zu refused, %zu warnings%s\n", path, warnings_count(errors),
               warnings_count(warnings) + warnings_dropped(warnings),
               renders ? "; it renders" : "; it does not render until the refusals are fixed");
    }
    scene_destroy(&scene);
    scene_desc_destroy(&desc);
    warnings_destroy(&errors);
    warnings_destroy(&warnings);
    return rc;
}
