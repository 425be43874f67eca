// mcpt: Monte Carlo path tracer with a k-d tree, on OpenCL (and Vulkan).
#include <CLI/CLI.hpp>
#include <iostream>
#include <new>

#include "app/commands.h"

int main(int argc, char** argv) {
    CLI::App app{"mcpt: Monte Carlo path tracer with a k-d tree (OpenCL reference, Vulkan port)"};
    app.require_subcommand(0, 1);
    mcpt::add_render_command(app);
    mcpt::add_devices_command(app);
    mcpt::add_tree_command(app);
    mcpt::add_compare_command(app);
    mcpt::add_converge_command(app);
    mcpt::add_bench_command(app);
    try {
        app.parse(argc, argv);
        // No subcommand: render the default scene on the best device.
        if (app.get_subcommands().empty()) return app.get_subcommand("render")->parse(""), 0;
    } catch (const mcpt::ExitStatus& e) {
        return e.code;
    } catch (const CLI::ParseError& e) {
        // CLI11's message; bad options are bad input: exit status 1 (--help: 0).
        return app.exit(e) == 0 ? 0 : 1;
    } catch (const std::bad_alloc&) {
        // A size no check foresaw: say what ran out, still exit cleanly.
        std::cerr << "mcpt: error: out of host memory (an allocation failed)\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "mcpt: error: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
