#pragma once
// The rgbdmap subcommands; each takes the arguments after its name and returns the exit code.
namespace rgbdmap::cmd {
int synth(int argc, char** argv);
int odometry(int argc, char** argv);
int eval(int argc, char** argv);
int run(int argc, char** argv);
int viewMap(int argc, char** argv);
}  // namespace rgbdmap::cmd
