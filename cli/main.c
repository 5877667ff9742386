/* prismfarm: one executable, many subcommands (git style). */
#include "commands.h"

#include <stdio.h>
#include "suggest.h"

#include <string.h>

typedef struct command {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
} command_t;

static const command_t COMMANDS[] = {
    {"render", cmd_render, "render a scene on this machine (a master and workers in-process)"},
    {"master", cmd_master,
     "run the farm's master: take jobs, hand tiles to workers, write outputs"},
    {"worker", cmd_worker, "render tasks for a master (a farm worker)"},
    {"submit", cmd_submit, "submit a scene to a master (--wait: follow it and fetch the result)"},
    {"status", cmd_status, "show one job or all jobs of a master"},
    {"jobs", cmd_jobs, "list a master's jobs"},
    {"workers", cmd_workers, "list a master's workers"},
    {"fetch", cmd_fetch, "download a finished job's EXR and PNG"},
    {"cancel", cmd_cancel, "cancel a job"},
    {"refine", cmd_refine, "add photons to a finished photon job and render it again"},
    {"priority", cmd_priority, "change a job's priority (higher runs first)"},
    {"pause", cmd_pause, "pause a job: workers finish their tasks of it and take no more"},
    {"resume", cmd_resume, "resume a paused job"},
    {"requeue", cmd_requeue, "put a stuck task of a job back in the queue"},
    {"unblock", cmd_unblock, "let a blocked worker take tasks again"},
    {"logs", cmd_logs, "print a job's task log (one task's with TASK)"},
    {"metrics", cmd_metrics, "print the master's metrics (Prometheus text format)"},
    {"glass", cmd_glass, "list the glass catalogue and print refractive indices"},
    {"plan", cmd_plan, "print the effects a scene calls for (dispersion, photons) and why"},
    {"check", cmd_check, "list every refusal and warning of a scene (pbrt-v4 porting)"},
    {"upgrade", cmd_upgrade, "rewrite a pbrt-v3 scene file for pbrt-v4 (as pbrt --upgrade)"},
    {"keygen", cmd_keygen, "write a CURVE key pair (NAME.key, NAME.pub) for the farm's encryption"},
};

#define COMMAND_COUNT (sizeof COMMANDS / sizeof COMMANDS[0])

static void print_help(FILE *out)
{
    fprintf(out,
            "prismfarm: a distributed spectral renderer for light dispersion\n"
            "\n"
            "usage: prismfarm <command> [options]\n"
            "       prismfarm <command> --help\n"
            "\n"
            "commands:\n");
    for (size_t i = 0; i < COMMAND_COUNT; i++)
        fprintf(out, "  %-10s %s\n", COMMANDS[i].name, COMMANDS[i].summary);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        print_help(stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        print_help(stdout);
        return 0;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("prismfarm 0.1.0\n");
        return 0;
    }
    for (size_t i = 0; i < COMMAND_COUNT; i++)
        if (!strcmp(argv[1], COMMANDS[i].name))
            return COMMANDS[i].run(argc - 1, argv + 1);
    suggest_t near = suggest_begin(argv[1]);
    for (size_t i = 0; i < COMMAND_COUNT; i++)
        suggest_consider(&near, COMMANDS[i].name);
    const char *best = suggest_result(&near);
    if (best)
        fprintf(stderr, "prismfarm: unknown command '%s' (did you mean '%s'? try 'prismfarm --help')\n",
                argv[1], best);
    else
        fprintf(stderr, "prismfarm: unknown command '%s' (try 'prismfarm --help')\n", argv[1]);
    return 2;
}
