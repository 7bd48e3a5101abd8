// Helpers for the link tests: a peer made of the OpenIGTLink library's own client socket and
// message classes, and waiting for the link thread.
#pragma once

#include <igtlClientSocket.h>
#include <igtlMessageHeader.h>
#include <igtlSensorMessage.h>
#include <igtlTransformMessage.h>

#include <chrono>
#include <string>
#include <thread>

namespace tsf::link::test {

/// Waits (up to 5 s) until `done()`.
template <typename F>
bool eventually(F done) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (std::chrono::steady_clock::now() < until) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return done();
}

/// A client connected to 127.0.0.1:`port`, receiving with a 5 s timeout (null when refused).
inline igtl::ClientSocket::Pointer connect_to_port(int port) {
  igtl::ClientSocket::Pointer s = igtl::ClientSocket::New();
  if (s->ConnectToServer("127.0.0.1", port) != 0) return nullptr;
  s->SetReceiveTimeout(5000);
  return s;
}

/// Sends TRANSFORM `device`: the identity rotation at (x, y, z).
inline void send_transform(igtl::ClientSocket::Pointer& s, const std::string& device, float x,
                           float y, float z) {
  igtl::TransformMessage::Pointer msg = igtl::TransformMessage::New();
  msg->SetDeviceName(device.c_str());
  igtl::Matrix4x4 m;
  igtl::IdentityMatrix(m);
  m[0][3] = x;
  m[1][3] = y;
  m[2][3] = z;
  msg->SetMatrix(m);
  msg->Pack();
  s->Send(msg->GetPackPointer(), msg->GetPackSize());
}

/// The next message's header (null when the socket closed or timed out).
inline igtl::MessageHeader::Pointer receive_header(igtl::ClientSocket::Pointer& s) {
  igtl::MessageHeader::Pointer h = igtl::MessageHeader::New();
  h->InitPack();
  if (s->Receive(h->GetPackPointer(), h->GetPackSize()) != h->GetPackSize()) return nullptr;
  h->Unpack();
  return h;
}

/// The SENSOR whose header `h` was just received, its body read and CRC checked (null when not).
inline igtl::SensorMessage::Pointer receive_sensor(igtl::ClientSocket::Pointer& s,
                                                   const igtl::MessageHeader::Pointer& h) {
  igtl::SensorMessage::Pointer sensor = igtl::SensorMessage::New();
  sensor->SetMessageHeader(h);
  sensor->AllocatePack();
  if (s->Receive(sensor->GetPackBodyPointer(), sensor->GetPackBodySize()) !=
      sensor->GetPackBodySize())
    return nullptr;
  if (!(sensor->Unpack(1) & igtl::MessageHeader::UNPACK_BODY)) return nullptr;
  return sensor;
}

}  // namespace tsf::link::test
