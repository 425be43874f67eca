// ptx-replay: runs one dispatch of mcpt's OpenCL kernel, as NVIDIA's OpenCL compiled it (PTX),
// through the CUDA driver API, so that Nsight Compute (ncu), which sees no OpenCL, profiles
// the identical kernel on the identical buffers. A profiling tool, not part of mcpt.
//
//   MCPT_DUMP_DISPATCH=DIR[:N] mcpt render ... --backend opencl --device NVIDIA   (the dump)
//   ptx-replay DIR [launches]                                                    (the replay)
//   ncu --set full ptx-replay DIR                                                (the profile)
//
// The dump holds kernel.ptx, launch.txt (kernel name, global and local size, argument count,
// build options), argI.bin (every buffer argument before the dispatch) and the accumulation
// buffer after it (argLAST.after.bin). The replay restores the buffers before each launch and
// compares the accumulation sums with OpenCL's after the first. libcuda comes with the NVIDIA
// driver; it is opened at run time. The JIT gets the register limit of the OpenCL build, so this
// builds without the CUDA toolkit:
//   g++ -O2 -std=c++17 scripts/ptx-replay.cpp -o ptx-replay -ldl
#include <dlfcn.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

// The few CUDA driver API entry points used (cuda.h's declarations, by value).
using CUresult = int;
using CUdeviceptr = unsigned long long;
using Handle = void*;
struct Cuda {
    CUresult (*cuInit)(unsigned);
    CUresult (*cuDeviceGet)(int*, int);
    CUresult (*cuDevicePrimaryCtxRetain)(Handle*, int);
    CUresult (*cuCtxSetCurrent)(Handle);
    CUresult (*cuModuleLoadDataEx)(Handle*, const void*, unsigned, int*, void**);
    CUresult (*cuModuleGetFunction)(Handle*, Handle, const char*);
    CUresult (*cuFuncGetAttribute)(int*, int, Handle);
    CUresult (*cuMemAlloc)(CUdeviceptr*, size_t);
    CUresult (*cuMemcpyHtoD)(CUdeviceptr, const void*, size_t);
    CUresult (*cuMemcpyDtoH)(void*, CUdeviceptr, size_t);
    CUresult (*cuLaunchKernel)(Handle, unsigned, unsigned, unsigned, unsigned, unsigned, unsigned,
                               unsigned, Handle, void**, void**);
    CUresult (*cuCtxSynchronize)();
    CUresult (*cuGetErrorString)(CUresult, const char**);
};
Cuda cu;

[[noreturn]] void fail(const std::string& what) {
    std::fprintf(stderr, "ptx-replay: %s\n", what.c_str());
    std::exit(1);
}

void check(CUresult r, const char* call) {
    if (r == 0) return;
    const char* s = "unknown error";
    if (cu.cuGetErrorString) cu.cuGetErrorString(r, &s);
    fail(std::string(call) + " failed: " + s + " (" + std::to_string(r) + ")");
}

void load_cuda() {
    void* lib = dlopen("libcuda.so.1", RTLD_NOW);
    if (!lib) fail(std::string("cannot open libcuda.so.1 (the NVIDIA driver): ") + dlerror());
    const auto sym = [&](const char* name) {
        void* p = dlsym(lib, name);
        if (!p) fail(std::string("libcuda has no ") + name);
        return p;
    };
    cu.cuInit = reinterpret_cast<decltype(cu.cuInit)>(sym("cuInit"));
    cu.cuDeviceGet = reinterpret_cast<decltype(cu.cuDeviceGet)>(sym("cuDeviceGet"));
    cu.cuDevicePrimaryCtxRetain =
        reinterpret_cast<decltype(cu.cuDevicePrimaryCtxRetain)>(sym("cuDevicePrimaryCtxRetain"));
    cu.cuCtxSetCurrent = reinterpret_cast<decltype(cu.cuCtxSetCurrent)>(sym("cuCtxSetCurrent"));
    cu.cuModuleLoadDataEx =
        reinterpret_cast<decltype(cu.cuModuleLoadDataEx)>(sym("cuModuleLoadDataEx"));
    cu.cuModuleGetFunction =
        reinterpret_cast<decltype(cu.cuModuleGetFunction)>(sym("cuModuleGetFunction"));
    cu.cuFuncGetAttribute =
        reinterpret_cast<decltype(cu.cuFuncGetAttribute)>(sym("cuFuncGetAttribute"));
    cu.cuMemAlloc = reinterpret_cast<decltype(cu.cuMemAlloc)>(sym("cuMemAlloc_v2"));
    cu.cuMemcpyHtoD = reinterpret_cast<decltype(cu.cuMemcpyHtoD)>(sym("cuMemcpyHtoD_v2"));
    cu.cuMemcpyDtoH = reinterpret_cast<decltype(cu.cuMemcpyDtoH)>(sym("cuMemcpyDtoH_v2"));
    cu.cuLaunchKernel = reinterpret_cast<decltype(cu.cuLaunchKernel)>(sym("cuLaunchKernel"));
    cu.cuCtxSynchronize = reinterpret_cast<decltype(cu.cuCtxSynchronize)>(sym("cuCtxSynchronize"));
    cu.cuGetErrorString = reinterpret_cast<decltype(cu.cuGetErrorString)>(sym("cuGetErrorString"));
}

std::vector<char> read_file(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) fail("cannot read " + path);
    return std::vector<char>(std::istreambuf_iterator<char>(f), {});
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) fail("usage: ptx-replay DIR [launches]");
    const std::string dir = argv[1];
    const int launches = argc > 2 ? std::max(1, std::atoi(argv[2])) : 1;
    // The dump: launch size, program, buffers.
    const std::vector<char> launch_text = read_file(dir + "/launch.txt");
    std::istringstream launch(std::string(launch_text.begin(), launch_text.end()));
    std::string name;
    size_t global = 0, local = 0;
    int nargs = 0;
    launch >> name >> global >> local >> nargs;
    if (name.empty() || global == 0 || local == 0 || nargs <= 0) fail("malformed launch.txt");
    std::vector<char> ptx = read_file(dir + "/kernel.ptx");
    ptx.push_back('\0');
    std::vector<std::vector<char>> args(nargs);
    for (int i = 0; i < nargs; ++i) args[i] = read_file(dir + "/arg" + std::to_string(i) + ".bin");
    const std::vector<char> expected =
        read_file(dir + "/arg" + std::to_string(nargs - 1) + ".after.bin");

    // The CUDA context, the module from the PTX, the kernel and its registers.
    load_cuda();
    check(cu.cuInit(0), "cuInit");
    int device = 0;
    check(cu.cuDeviceGet(&device, 0), "cuDeviceGet");
    Handle ctx = nullptr, module = nullptr, kernel = nullptr;
    check(cu.cuDevicePrimaryCtxRetain(&ctx, device), "cuDevicePrimaryCtxRetain");
    check(cu.cuCtxSetCurrent(ctx), "cuCtxSetCurrent");
    // The JIT compiles the PTX as NVIDIA's OpenCL does: with its register limit, which the
    // PTX does not carry (-cl-nv-maxrregcount in the build options).
    std::string options;
    std::getline(launch, options);  // the rest of the first line
    std::getline(launch, options);
    int jit_option[1] = {0};  // CU_JIT_MAX_REGISTERS
    void* jit_value[1] = {nullptr};
    unsigned jit_options = 0;
    const size_t at = options.find("-cl-nv-maxrregcount=");
    if (at != std::string::npos) {
        const unsigned max_regs = unsigned(std::atoi(options.c_str() + at + 20));
        jit_value[0] = reinterpret_cast<void*>(uintptr_t(max_regs));
        jit_options = 1;
        std::printf("register limit %u (from the OpenCL build options)\n", max_regs);
    }
    check(cu.cuModuleLoadDataEx(&module, ptx.data(), jit_options, jit_option, jit_value),
          "cuModuleLoadDataEx");
    check(cu.cuModuleGetFunction(&kernel, module, name.c_str()), "cuModuleGetFunction");
    int regs = 0, local_bytes = 0;
    check(cu.cuFuncGetAttribute(&regs, 4, kernel), "cuFuncGetAttribute");         // NUM_REGS
    check(cu.cuFuncGetAttribute(&local_bytes, 3, kernel), "cuFuncGetAttribute");  // LOCAL_SIZE
    std::printf("%s: %zu work-items in groups of %zu, %d registers, %d bytes local memory\n",
                name.c_str(), global, local, regs, local_bytes);

    // Buffers, restored before every launch; OpenCL's pointer arguments are device pointers.
    std::vector<CUdeviceptr> ptrs(nargs);
    std::vector<void*> params(nargs);
    for (int i = 0; i < nargs; ++i) {
        check(cu.cuMemAlloc(&ptrs[i], args[i].size()), "cuMemAlloc");
        params[i] = &ptrs[i];
    }
    std::vector<char> out(args[nargs - 1].size());
    for (int l = 0; l < launches; ++l) {
        for (int i = 0; i < nargs; ++i)
            check(cu.cuMemcpyHtoD(ptrs[i], args[i].data(), args[i].size()), "cuMemcpyHtoD");
        check(cu.cuLaunchKernel(kernel, unsigned(global / local), 1, 1, unsigned(local), 1, 1, 0,
                                nullptr, params.data(), nullptr),
              "cuLaunchKernel");
        check(cu.cuCtxSynchronize(), "cuCtxSynchronize");
        if (l > 0) continue;
        // The same kernel on the same buffers: the sums must be OpenCL's, word for word.
        check(cu.cuMemcpyDtoH(out.data(), ptrs[nargs - 1], out.size()), "cuMemcpyDtoH");
        size_t words = std::min(out.size(), expected.size()) / 4, differ = 0;
        for (size_t w = 0; w < words; ++w)
            differ += std::memcmp(&out[4 * w], &expected[4 * w], 4) != 0;
        std::printf("accumulation buffer after the launch: %zu of %zu words differ from OpenCL's\n",
                    differ, words);
    }
    return 0;
}
