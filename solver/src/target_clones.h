#pragma once
// HDEFORM_TARGET_CLONES("avx2", "default"): the function is compiled once per instruction set
// named, and the loader picks the one the CPU runs. Expands to nothing where that cannot work:
// off x86-64 GCC/Clang, and under AddressSanitizer or ThreadSanitizer, whose runtimes are not up
// yet when the ifunc resolvers run during relocation (ThreadSanitizer crashed there). Such builds
// run the baseline alone: the same lanes, the same arithmetic.

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define HDEFORM_SANITIZED_BUILD 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define HDEFORM_SANITIZED_BUILD 1
#endif
#endif

#if defined(__x86_64__) && defined(__GNUC__) && !defined(HDEFORM_SANITIZED_BUILD)
#define HDEFORM_TARGET_CLONES(...) [[gnu::target_clones(__VA_ARGS__)]]
#else
#define HDEFORM_TARGET_CLONES(...)
#endif
