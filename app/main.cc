// mcpt: Monte Carlo path tracer with a k-d tree, on OpenCL (and Vulkan).
#include <CLI/CLI.hpp>
#include <iostream>
#include <new>

#include "app/commands.h"
#include "app/mpi_job.h"

namespace {
// Under mpirun a failing rank ends the whole job (the others would wait for it forever).
int finish(int code) {
    if (code != 0 && mcpt::mpi_job().size > 1) {
        std::cerr.flush();
        mcpt::mpi_abort(code);
    }
    mcpt::mpi_finish();
    return code;
}
}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"mcpt: Monte Carlo path tracer with a k-d tree (OpenCL reference, Vulkan port)"};
    app.require_subcommand(0, 1);
    mcpt::add_render_command(app);
    mcpt::add_devices_command(app);
    mcpt::add_tree_command(app);
    mcpt::add_compare_command(app);
    mcpt::add_converge_command(app);
    mcpt::add_bench_command(app);
    mcpt::add_merge_command(app);
    mcpt::add_view_command(app);
    try {
        mcpt::mpi_start(argc, argv);
        app.parse(argc, argv);
        // No subcommand: render the default scene on the best device.
        if (app.get_subcommands().empty()) app.get_subcommand("render")->parse("");
    } catch (const mcpt::ExitStatus& e) {
        // A verdict (compare: DIFFER), given when every rank has done its part.
        mcpt::mpi_finish();
        return e.code;
    } catch (const CLI::ParseError& e) {
        // CLI11's message; bad options are bad input: exit status 1 (--help: 0).
        return finish(app.exit(e) == 0 ? 0 : 1);
    } catch (const std::bad_alloc&) {
        // A size no check foresaw: say what ran out, still exit cleanly.
        std::cerr << "mcpt: error: out of host memory (an allocation failed)\n";
        return finish(1);
    } catch (const std::exception& e) {
        const int rank = mcpt::mpi_job().rank;
        std::cerr << "mcpt: error: "
                  << (mcpt::mpi_job().size > 1 ? "rank " + std::to_string(rank) + ": " : "")
                  << e.what() << "\n";
        return finish(1);
    }
    return finish(0);
}
