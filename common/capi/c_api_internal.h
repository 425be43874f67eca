// What the C API's files share: handles as ids in a table (never pointers that a stale handle
// could reach), errors as a status and a message, and every exception caught at the boundary.
#pragma once
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <unordered_map>

#include "common/error.h"
#include "common/render/backend.h"
#include "common/scene/scene.h"
#include "mcpt/mcpt.h"

namespace mcpt::capi {

// A C-side error: the status and its message.
struct CError {
    mcpt_status status;
    std::string message;
};

// The live handles of one kind: handle value -> box. Each kind counts from its own base, so a
// handle of one kind is never a live handle of another.
template <class Box, class Handle>
class HandleTable {
  public:
    explicit HandleTable(uintptr_t base) : next_(base & ~uintptr_t(15)) {}
    Handle add(std::shared_ptr<Box> box) {
        std::lock_guard<std::mutex> lock(mutex_);
        const uintptr_t id = next_;
        next_ += 16;  // never 0, never a small integer
        boxes_[id] = std::move(box);
        return reinterpret_cast<Handle>(id);
    }
    std::shared_ptr<Box> find(Handle h) {
        std::lock_guard<std::mutex> lock(mutex_);
        auto it = boxes_.find(reinterpret_cast<uintptr_t>(h));
        return it == boxes_.end() ? nullptr : it->second;
    }
    std::shared_ptr<Box> remove(Handle h) {
        std::lock_guard<std::mutex> lock(mutex_);
        auto it = boxes_.find(reinterpret_cast<uintptr_t>(h));
        if (it == boxes_.end()) return nullptr;
        std::shared_ptr<Box> box = std::move(it->second);
        boxes_.erase(it);
        return box;
    }

  private:
    std::mutex mutex_;
    std::unordered_map<uintptr_t, std::shared_ptr<Box>> boxes_;
    uintptr_t next_;
};

// Failures without a live handle (create, or a call with a bad handle), per thread; and what
// the last *_last_error() call handed out.
inline thread_local std::string t_thread_error;
inline thread_local std::string t_returned_error;

inline mcpt_status thread_fail(mcpt_status status, const std::string& message) {
    t_thread_error = message;
    return status;
}

// Runs `body` with every exception turned into a status; `context` is the status that an
// mcpt::Error means in this call (a scene error while loading, a device error while rendering).
template <class Body>
mcpt_status guarded(mcpt_status context, std::string& message, Body&& body) {
    try {
        return body();
    } catch (const CError& e) {
        message = e.message;
        return e.status;
    } catch (const OutOfMemory& e) {
        message = e.what();
        return MCPT_ERROR_OUT_OF_MEMORY;
    } catch (const DeviceLost& e) {
        message = e.what();
        return MCPT_ERROR_DEVICE_LOST;
    } catch (const Error& e) {
        message = e.what();
        return context;
    } catch (const std::bad_alloc&) {
        message = "out of memory";
        return MCPT_ERROR_OUT_OF_MEMORY;
    } catch (const std::exception& e) {
        message = std::string("internal error: ") + e.what();
        return MCPT_ERROR_INTERNAL;
    } catch (...) {
        message = "internal error: unknown exception";
        return MCPT_ERROR_INTERNAL;
    }
}

// The box of a handle (taken out of the table when `remove`); null with the status set (and
// the thread's message) when the handle is not live. `what`: "session", "job".
template <class Box, class Handle>
std::shared_ptr<Box> lookup(HandleTable<Box, Handle>& table, Handle h, bool remove, mcpt_status& st,
                            const char* what) {
    std::shared_ptr<Box> box;
    try {
        box = remove ? table.remove(h) : table.find(h);
    } catch (...) {
        st = thread_fail(MCPT_ERROR_INTERNAL, "internal error: handle table");
        return nullptr;
    }
    if (!box) {
        st = thread_fail(
            MCPT_ERROR_INVALID_HANDLE,
            h == nullptr ? std::string("NULL ") + what + " handle"
                         : std::string("invalid ") + what + " handle (released or never created)");
    }
    return box;
}

// The message of the last failed call on a live handle (its box's last_error, guarded by its
// error_mutex), else of this thread's last failure without one.
template <class Box, class Handle>
const char* last_error_of(HandleTable<Box, Handle>& table, Handle h) {
    try {
        std::shared_ptr<Box> box = h ? table.find(h) : nullptr;
        if (box) {
            std::lock_guard<std::mutex> lock(box->error_mutex);
            t_returned_error = box->last_error;
        } else {
            t_returned_error = t_thread_error;
        }
    } catch (...) {
        return "out of memory";
    }
    return t_returned_error.c_str();
}

inline void copy(char* dst, size_t size, const std::string& src) {
    const size_t n = std::min(size - 1, src.size());
    std::memcpy(dst, src.data(), n);
    dst[n] = '\0';
}

inline void require(bool ok, const char* message) {
    if (!ok) throw CError{MCPT_ERROR_INVALID_ARGUMENT, message};
}

mcpt_device_info device_info(const DeviceInfo& d);

// A scene of the C API: a file, bytes in memory or a built-in name, its lights picked as the
// command line's --light-sampling auto picks them.
Scene scene_from_file(const char* path);
Scene scene_from_memory(const void* data, size_t size, const char* base_dir);
Scene scene_builtin(const char* name);

}  // namespace mcpt::capi
