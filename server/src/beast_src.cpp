// The non-template parts of Boost.Asio and Boost.Beast, compiled once for the whole program
// (BOOST_ASIO_SEPARATE_COMPILATION / BOOST_BEAST_SEPARATE_COMPILATION are set on facecast::server).
#include <boost/asio/impl/src.hpp>
#include <boost/beast/src.hpp>
