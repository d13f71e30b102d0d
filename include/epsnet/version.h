/*
 * epsnet version. This is the one place the version is written: meson.build
 * reads these three lines to version the library, the pkg-config file and the
 * `epsnet --version` output.
 */
#ifndef EPSNET_VERSION_H
#define EPSNET_VERSION_H

#define EPSNET_VERSION_MAJOR 0
#define EPSNET_VERSION_MINOR 1
#define EPSNET_VERSION_PATCH 0

#define EPSNET_VERSION_NUMBER \
    (EPSNET_VERSION_MAJOR * 10000 + EPSNET_VERSION_MINOR * 100 + EPSNET_VERSION_PATCH)

#endif /* EPSNET_VERSION_H */
