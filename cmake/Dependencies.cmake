# Imported targets for Debian packages whose own CMake files are missing or broken.
find_package(PkgConfig REQUIRED)

# OpenImageIO: Debian 12's CMake config references OpenCV headers and tool binaries that need not
# be installed; its pkg-config file is enough. Target: facecast::oiio.
pkg_check_modules(FACECAST_OIIO REQUIRED IMPORTED_TARGET OpenImageIO)
add_library(facecast::oiio ALIAS PkgConfig::FACECAST_OIIO)

# CHOLMOD (SuiteSparse): Debian 12 ships neither a CMake config nor a pkg-config file.
# Target: facecast::cholmod.
find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse REQUIRED)
find_library(CHOLMOD_LIBRARY cholmod REQUIRED)
add_library(facecast_cholmod INTERFACE)
target_include_directories(facecast_cholmod SYSTEM INTERFACE ${CHOLMOD_INCLUDE_DIR})
target_link_libraries(facecast_cholmod INTERFACE ${CHOLMOD_LIBRARY})
add_library(facecast::cholmod ALIAS facecast_cholmod)

# libjwt (viewer tokens, JWT HS256): Debian 12 ships only a pkg-config file. Target: facecast::jwt.
pkg_check_modules(FACECAST_JWT REQUIRED IMPORTED_TARGET libjwt)
add_library(facecast::jwt ALIAS PkgConfig::FACECAST_JWT)

# libwebp (EXT_texture_webp textures; OpenImageIO 2.4's WebP reader takes only files): Debian 12
# ships only a pkg-config file. Target: facecast::webp.
pkg_check_modules(FACECAST_WEBP REQUIRED IMPORTED_TARGET libwebp)
add_library(facecast::webp ALIAS PkgConfig::FACECAST_WEBP)
