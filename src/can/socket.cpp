#include "sph/can/socket.hpp"

#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/netlink.h>
#include <linux/can/raw.h>
#include <linux/net_tstamp.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <linux/sock_diag.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "sph/core/error.hpp"

namespace sph::can {
namespace {

static_assert(kEffFlag == CAN_EFF_FLAG && kRtrFlag == CAN_RTR_FLAG && kErrFlag == CAN_ERR_FLAG,
              "sph::can flag bits must match <linux/can.h>");
static_assert(kSffMask == CAN_SFF_MASK && kEffMask == CAN_EFF_MASK && kErrMask == CAN_ERR_MASK);
static_assert(kMaxDataBytes == CAN_MAX_DLEN);

std::string Fail(const std::string& iface, const char* call, int err) {
  return iface + ": " + call + ": " + std::strerror(err);
}

bool IsDownError(int err) { return err == ENETDOWN || err == ENODEV || err == ENXIO; }

std::int64_t NowNs() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

}  // namespace

const char* ToString(TimestampSource s) {
  switch (s) {
    case TimestampSource::kHardware:
      return "hardware";
    case TimestampSource::kKernel:
      return "kernel";
    case TimestampSource::kUser:
      return "user space";
  }
  return "?";
}

CanSocket::CanSocket(const CanSocketOptions& o) : iface_(o.iface) {
  if (o.iface.empty() || o.iface.size() >= IFNAMSIZ) {
    throw Error("'" + o.iface + "': a CAN interface name must have 1.." + std::to_string(IFNAMSIZ - 1) + " characters");
  }
  fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd_ < 0) throw Error(Fail(iface_, "socket(PF_CAN, SOCK_RAW, CAN_RAW)", errno));
  auto check = [&](int rc, const char* call) {
    if (rc != 0) {
      const int err = errno;
      ::close(fd_);
      fd_ = -1;
      throw Error(Fail(iface_, call, err));
    }
  };
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, o.iface.c_str(), IFNAMSIZ - 1);
  check(::ioctl(fd_, SIOCGIFINDEX, &ifr), "ioctl(SIOCGIFINDEX)");

  std::vector<can_filter> filters;
  for (const auto& [id, mask] : o.filters) filters.push_back(can_filter{id, mask});
  if (!filters.empty()) {
    check(::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
                       static_cast<socklen_t>(filters.size() * sizeof(can_filter))),
          "setsockopt(CAN_RAW_FILTER)");
  }
  const can_err_mask_t err_mask = o.error_mask & CAN_ERR_MASK;
  check(::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask),
        "setsockopt(CAN_RAW_ERR_FILTER)");
  const int own = o.receive_own ? 1 : 0;
  check(::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &own, sizeof own), "setsockopt(CAN_RAW_RECV_OWN_MSGS)");
  const int one = 1;
  check(::setsockopt(fd_, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one), "setsockopt(SO_RXQ_OVFL)");
  if (o.rcvbuf_bytes > 0) {
    check(::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &o.rcvbuf_bytes, sizeof o.rcvbuf_bytes), "setsockopt(SO_RCVBUF)");
  }
  const int ts_flags = SOF_TIMESTAMPING_RX_SOFTWARE | SOF_TIMESTAMPING_SOFTWARE | SOF_TIMESTAMPING_RX_HARDWARE |
                       SOF_TIMESTAMPING_RAW_HARDWARE;
  if (::setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPING, &ts_flags, sizeof ts_flags) == 0) {
    timestamping_ = true;
    ts_mode_ = TimestampSource::kKernel;
  } else {
    check(::setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMP, &one, sizeof one), "setsockopt(SO_TIMESTAMP)");
    ts_mode_ = TimestampSource::kKernel;
  }
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifr.ifr_ifindex;
  check(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), "bind");
}

CanSocket::~CanSocket() {
  if (fd_ >= 0) ::close(fd_);
}

CanSocket::CanSocket(CanSocket&& other) noexcept
    : fd_(other.fd_),
      iface_(std::move(other.iface_)),
      ts_mode_(other.ts_mode_),
      timestamping_(other.timestamping_),
      last_drops_(other.last_drops_) {
  other.fd_ = -1;
}

CanSocket& CanSocket::operator=(CanSocket&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.fd_;
    iface_ = std::move(other.iface_);
    ts_mode_ = other.ts_mode_;
    timestamping_ = other.timestamping_;
    last_drops_ = other.last_drops_;
    other.fd_ = -1;
  }
  return *this;
}

RxResult CanSocket::Receive() {
  RxResult r;
  can_frame cf{};
  iovec iov{&cf, sizeof cf};
  alignas(cmsghdr) char
      control[CMSG_SPACE(3 * sizeof(timespec)) + CMSG_SPACE(sizeof(timeval)) + CMSG_SPACE(sizeof(std::uint32_t))];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
  if (n < 0) {
    r.error = errno;
    r.status = IsDownError(r.error) ? RxStatus::kDown : RxStatus::kNone;
    if (!IsDownError(r.error) && r.error != EAGAIN && r.error != EWOULDBLOCK && r.error != EINTR) {
      r.status = RxStatus::kDown;  // any other socket error: treat like a lost interface and reopen
    }
    return r;
  }
  std::int64_t t_ns = 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SCM_TIMESTAMPING) {
      timespec ts[3];
      std::memcpy(ts, CMSG_DATA(c), sizeof ts);
      if (ts[2].tv_sec != 0 || ts[2].tv_nsec != 0) {  // raw hardware time
        t_ns = static_cast<std::int64_t>(ts[2].tv_sec) * 1000000000 + ts[2].tv_nsec;
        r.source = TimestampSource::kHardware;
      } else if (ts[0].tv_sec != 0 || ts[0].tv_nsec != 0) {
        t_ns = static_cast<std::int64_t>(ts[0].tv_sec) * 1000000000 + ts[0].tv_nsec;
        r.source = TimestampSource::kKernel;
      }
    } else if (c->cmsg_type == SCM_TIMESTAMP) {
      timeval tv{};
      std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
      t_ns = static_cast<std::int64_t>(tv.tv_sec) * 1000000000 + static_cast<std::int64_t>(tv.tv_usec) * 1000;
      r.source = TimestampSource::kKernel;
    } else if (c->cmsg_type == SO_RXQ_OVFL) {
      std::uint32_t drops = 0;
      std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
      r.new_drops = AdvanceDropCounter(&last_drops_, drops);
    }
  }
  if (n != static_cast<ssize_t>(CAN_MTU) || cf.can_dlc > CAN_MAX_DLEN) {
    r.status = RxStatus::kMalformed;
    return r;
  }
  r.status = RxStatus::kFrame;
  r.own = (msg.msg_flags & MSG_CONFIRM) != 0;
  r.frame.id = cf.can_id;
  r.frame.len = cf.can_dlc;
  std::memcpy(r.frame.data.data(), cf.data, CAN_MAX_DLEN);
  r.frame.t_ns = t_ns != 0 ? t_ns : NowNs();
  return r;
}

RxResult CanSocket::Receive(int timeout_ms) {
  pollfd p{fd_, POLLIN, 0};
  const int rc = ::poll(&p, 1, timeout_ms);
  if (rc <= 0) return RxResult{};  // timeout or EINTR
  return Receive();
}

TxStatus CanSocket::Send(const CanFrame& frame, int* error) {
  can_frame cf{};
  cf.can_id = frame.id;
  cf.can_dlc = frame.len > CAN_MAX_DLEN ? CAN_MAX_DLEN : frame.len;
  std::memcpy(cf.data, frame.data.data(), CAN_MAX_DLEN);
  for (;;) {
    const ssize_t n = ::write(fd_, &cf, sizeof cf);
    if (n == static_cast<ssize_t>(sizeof cf)) return TxStatus::kOk;
    const int err = n < 0 ? errno : EIO;
    if (err == EINTR) continue;
    if (error != nullptr) *error = err;
    return (err == ENOBUFS || err == EAGAIN) ? TxStatus::kBusy : TxStatus::kDown;
  }
}

std::uint64_t CanSocket::TakeDrops() {
  std::uint32_t info[SK_MEMINFO_VARS] = {};
  socklen_t len = sizeof info;
  if (::getsockopt(fd_, SOL_SOCKET, SO_MEMINFO, info, &len) != 0 || len <= SK_MEMINFO_DROPS * sizeof info[0]) return 0;
  return AdvanceDropCounter(&last_drops_, info[SK_MEMINFO_DROPS]);
}

std::uint64_t AdvanceDropCounter(std::uint32_t* last, std::uint32_t counter) {
  const std::uint32_t diff = counter - *last;     // the kernel counter wraps at 2^32
  if (diff == 0 || diff > 0x7fffffffU) return 0;  // unchanged, or an older reading
  *last = counter;
  return diff;
}

bool InterfaceIsUp(const std::string& iface) {
  if (iface.empty() || iface.size() >= IFNAMSIZ) return false;
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) return false;
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, iface.c_str(), IFNAMSIZ - 1);
  const bool up = ::ioctl(fd, SIOCGIFFLAGS, &ifr) == 0 && (ifr.ifr_flags & IFF_UP) != 0;
  ::close(fd);
  return up;
}

std::optional<std::uint32_t> InterfaceBitrate(const std::string& iface) {
  const unsigned index = iface.empty() || iface.size() >= IFNAMSIZ ? 0 : ::if_nametoindex(iface.c_str());
  if (index == 0) return std::nullopt;
  const int fd = ::socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_ROUTE);
  if (fd < 0) return std::nullopt;
  struct {
    nlmsghdr header;
    ifinfomsg info;
  } request{};
  request.header.nlmsg_len = NLMSG_LENGTH(sizeof(ifinfomsg));
  request.header.nlmsg_type = RTM_GETLINK;
  request.header.nlmsg_flags = NLM_F_REQUEST;
  request.header.nlmsg_seq = 1;
  request.info.ifi_family = AF_UNSPEC;
  request.info.ifi_index = static_cast<int>(index);
  std::optional<std::uint32_t> bitrate;
  alignas(nlmsghdr) char buffer[16384];
  timeval timeout{1, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  const ssize_t n = ::send(fd, &request, request.header.nlmsg_len, 0) < 0 ? -1 : ::recv(fd, buffer, sizeof buffer, 0);
  ::close(fd);
  if (n <= 0) return std::nullopt;
  // The link message: IFLA_LINKINFO holds IFLA_INFO_DATA, which holds IFLA_CAN_BITTIMING.
  const auto* h = reinterpret_cast<const nlmsghdr*>(buffer);
  if (!NLMSG_OK(h, static_cast<unsigned>(n)) || h->nlmsg_type != RTM_NEWLINK) return std::nullopt;
  const auto* info = static_cast<const ifinfomsg*>(NLMSG_DATA(h));
  int len = static_cast<int>(h->nlmsg_len) - static_cast<int>(NLMSG_LENGTH(sizeof(ifinfomsg)));
  for (const rtattr* a = IFLA_RTA(info); RTA_OK(a, len); a = RTA_NEXT(a, len)) {
    if (a->rta_type != IFLA_LINKINFO) continue;
    int len2 = static_cast<int>(RTA_PAYLOAD(a));
    for (const rtattr* b = static_cast<const rtattr*>(RTA_DATA(a)); RTA_OK(b, len2); b = RTA_NEXT(b, len2)) {
      if (b->rta_type != IFLA_INFO_DATA) continue;
      int len3 = static_cast<int>(RTA_PAYLOAD(b));
      for (const rtattr* c = static_cast<const rtattr*>(RTA_DATA(b)); RTA_OK(c, len3); c = RTA_NEXT(c, len3)) {
        if (c->rta_type != IFLA_CAN_BITTIMING || RTA_PAYLOAD(c) < sizeof(can_bittiming)) continue;
        can_bittiming timing{};
        std::memcpy(&timing, RTA_DATA(c), sizeof timing);
        if (timing.bitrate > 0) bitrate = timing.bitrate;
      }
    }
  }
  return bitrate;
}

bool CanSupported(std::string* why) {
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    if (why != nullptr) *why = std::string("socket(PF_CAN, SOCK_RAW, CAN_RAW): ") + std::strerror(errno);
    return false;
  }
  ::close(fd);
  return true;
}

}  // namespace sph::can
