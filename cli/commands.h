/* commands: the subcommands of the `prismfarm` executable. Each takes the arguments after
 * its own name (argv[0] is the subcommand) and returns the process exit status:
 * 0 success, 1 failure at run time, 2 bad command line. */
#ifndef PRISMFARM_COMMANDS_H
#define PRISMFARM_COMMANDS_H

int cmd_glass(int argc, char **argv);
int cmd_plan(int argc, char **argv);
int cmd_check(int argc, char **argv);
int cmd_upgrade(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_worker(int argc, char **argv);
int cmd_master(int argc, char **argv);
int cmd_submit(int argc, char **argv);
int cmd_status(int argc, char **argv);
int cmd_jobs(int argc, char **argv);
int cmd_workers(int argc, char **argv);
int cmd_cancel(int argc, char **argv);
int cmd_refine(int argc, char **argv);
int cmd_fetch(int argc, char **argv);
int cmd_keygen(int argc, char **argv);
int cmd_priority(int argc, char **argv);
int cmd_pause(int argc, char **argv);
int cmd_resume(int argc, char **argv);
int cmd_requeue(int argc, char **argv);
int cmd_unblock(int argc, char **argv);
int cmd_logs(int argc, char **argv);
int cmd_metrics(int argc, char **argv);


#endif
