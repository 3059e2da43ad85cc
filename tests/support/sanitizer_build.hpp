#pragma once
// Which sanitizer this test program is built with, whatever the compiler: GCC defines __SANITIZE_ADDRESS__
// and __SANITIZE_THREAD__, clang 14 only answers __has_feature. Tests skip statistics and timing ratios there.

#if defined(__SANITIZE_ADDRESS__)
#define GUIDEWAY_SANITIZED_ADDRESS 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define GUIDEWAY_SANITIZED_ADDRESS 1
#endif
#endif

#if defined(__SANITIZE_THREAD__)
#define GUIDEWAY_SANITIZED_THREAD 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define GUIDEWAY_SANITIZED_THREAD 1
#endif
#endif
